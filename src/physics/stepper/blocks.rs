//! The decoupled blocks of a system: groups of states whose rates depend only on each
//! other (and on the inputs). Each block is discretised on its own, which keeps every
//! matrix exponential 1x1, 2x2 or 3x3 for the models here.

use crate::physics::math;
use crate::physics::signals::DrivingInput;
use crate::physics::state_space::{MAX_STATES, StateSpace};

/// One block: its states, and the power-of-two scaling that balances its matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Block {
    pub size: usize,
    /// State indices, ascending; the first `size` are used.
    pub states: [usize; MAX_STATES],
    /// Balancing: the block's matrix is discretised as `S^-1 X S`, S = diag(scale).
    pub scale: [f64; MAX_STATES],
    /// `1/scale` (exact: powers of two).
    pub inverse_scale: [f64; MAX_STATES],
    /// Which driving inputs enter the block's rates.
    pub driven_by: [bool; DrivingInput::COUNT],
}

impl Block {
    pub fn states(&self) -> &[usize] {
        &self.states[..self.size]
    }

    /// The driving inputs (as columns of B) that enter the block's rates.
    pub fn inputs(&self) -> impl Iterator<Item = usize> + '_ {
        (0..DrivingInput::COUNT).filter(|&k| self.driven_by[k])
    }
}

/// The blocks of a system, ordered by their first state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blocks {
    count: usize,
    blocks: [Block; MAX_STATES],
}

impl Blocks {
    /// The blocks of a system of `states` states whose state matrix has an entry of
    /// typical magnitude `magnitude[i][j]` (zero where it is zero at every operating point)
    /// and whose input matrix has a nonzero entry where `driven[i][k]`.
    pub fn new(
        states: usize,
        magnitude: &[[f64; MAX_STATES]; MAX_STATES],
        driven: &[[bool; DrivingInput::COUNT]; MAX_STATES],
    ) -> Self {
        // Connected components of the coupling graph (either direction couples).
        let mut component: [usize; MAX_STATES] = std::array::from_fn(|i| i);
        for _ in 0..states {
            for i in 0..states {
                for j in 0..states {
                    if magnitude[i][j] != 0.0 || magnitude[j][i] != 0.0 {
                        let lowest = component[i].min(component[j]);
                        component[i] = lowest;
                        component[j] = lowest;
                    }
                }
            }
        }
        let empty = Block {
            size: 0,
            states: [0; MAX_STATES],
            scale: [1.0; MAX_STATES],
            inverse_scale: [1.0; MAX_STATES],
            driven_by: [false; DrivingInput::COUNT],
        };
        let mut blocks = Blocks {
            count: 0,
            blocks: [empty; MAX_STATES],
        };
        for root in 0..states {
            let mut block = empty;
            for state in (0..states).filter(|&s| component[s] == root) {
                block.states[block.size] = state;
                block.size += 1;
                for (k, driven_by) in block.driven_by.iter_mut().enumerate() {
                    *driven_by |= driven[state][k];
                }
            }
            if block.size > 0 {
                balance(&mut block, magnitude);
                block.inverse_scale = block.scale.map(|s| 1.0 / s);
                blocks.blocks[blocks.count] = block;
                blocks.count += 1;
            }
        }
        blocks
    }

    /// The blocks of one system as it is (its own entries for the magnitudes), where no
    /// pattern over operating points is kept: a system made for a single step.
    pub fn of(system: &StateSpace) -> Self {
        let mut magnitude = [[0.0; MAX_STATES]; MAX_STATES];
        let mut driven = [[false; DrivingInput::COUNT]; MAX_STATES];
        for i in 0..system.states {
            for (j, entry) in magnitude[i].iter_mut().enumerate().take(system.states) {
                *entry = system.a[(i, j)].abs();
            }
            for (k, entry) in driven[i].iter_mut().enumerate() {
                *entry = system.b[(i, k)] != 0.0;
            }
        }
        Self::new(system.states, &magnitude, &driven)
    }

    pub fn iter(&self) -> impl Iterator<Item = &Block> {
        self.blocks[..self.count].iter()
    }
}

/// Osborne's balancing with powers of two: scales each state so that the off-diagonal
/// row and column sums of the block's matrix match. A contact mass couples metres to
/// metres per second through stiffness/mass ratios of 1e5 1/s^2; balanced, the matrix's
/// norm is its natural frequency, and the exponential needs few squarings.
fn balance(block: &mut Block, magnitude: &[[f64; MAX_STATES]; MAX_STATES]) {
    let n = block.size;
    for _sweep in 0..16 {
        let mut changed = false;
        for i in 0..n {
            let (mut row, mut column) = (0.0, 0.0);
            for j in (0..n).filter(|&j| j != i) {
                let (si, sj) = (block.states[i], block.states[j]);
                row += magnitude[si][sj] * block.scale[j] / block.scale[i];
                column += magnitude[sj][si] * block.scale[i] / block.scale[j];
            }
            if row == 0.0 || column == 0.0 {
                continue;
            }
            // Multiplying scale[i] by f divides row i by f and multiplies column i by f.
            let exponent = (0.5 * math::log2(row / column)).round();
            if exponent != 0.0 {
                block.scale[i] *= super::phi::power_of_two(exponent as i32);
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pattern(entries: &[(usize, usize, f64)]) -> [[f64; MAX_STATES]; MAX_STATES] {
        let mut m = [[0.0; MAX_STATES]; MAX_STATES];
        for &(i, j, v) in entries {
            m[i][j] = v;
        }
        m
    }

    #[test]
    fn blocks_are_the_coupled_groups_of_states() {
        // 0 <- 2 coupled, 1 alone, 3 <-> 4.
        let m = pattern(&[(0, 0, 1.0), (2, 0, 3.0), (1, 1, 1.0), (3, 4, 1.0), (4, 3, 1.0)]);
        let blocks = Blocks::new(5, &m, &[[true; DrivingInput::COUNT]; MAX_STATES]);
        let groups: Vec<Vec<usize>> = blocks.iter().map(|b| b.states().to_vec()).collect();
        assert_eq!(groups, vec![vec![0, 2], vec![1], vec![3, 4]]);
    }

    #[test]
    fn balancing_evens_out_a_stiff_mass() {
        // eta' = w, w' = -1e5 eta: balanced, both off-diagonal entries are about 316.
        let m = pattern(&[(0, 1, 1.0), (1, 0, 1e5)]);
        let block = *Blocks::new(2, &m, &[[true; DrivingInput::COUNT]; MAX_STATES])
            .iter()
            .next()
            .unwrap();
        let upper = m[0][1] * block.scale[1] / block.scale[0];
        let lower = m[1][0] * block.scale[0] / block.scale[1];
        assert!(upper / lower < 4.0 && lower / upper < 4.0, "{upper} {lower}");
        assert!(block.scale.iter().all(|s| s.log2().fract() == 0.0));
    }
}
