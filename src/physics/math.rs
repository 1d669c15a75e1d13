//! The elementary functions the physics uses, from the pure-Rust `libm` crate rather than
//! the platform's C library. Each C library rounds some results differently (Windows'
//! msvcrt against glibc, for one), and an adaptive step turns a last-bit difference into a
//! different substep sequence; with these, every platform computes the same bits. `sqrt`,
//! `abs`, `floor`, `round` and `powi` are exact or made of exact operations everywhere and
//! stay the standard library's.

pub fn exp(x: f64) -> f64 {
    libm::exp(x)
}

/// `exp(x) - 1`, accurate near zero.
pub fn exp_m1(x: f64) -> f64 {
    libm::expm1(x)
}

pub fn ln(x: f64) -> f64 {
    libm::log(x)
}

/// `ln(1 + x)`, accurate near zero.
pub fn ln_1p(x: f64) -> f64 {
    libm::log1p(x)
}

pub fn log2(x: f64) -> f64 {
    libm::log2(x)
}

pub fn powf(x: f64, y: f64) -> f64 {
    libm::pow(x, y)
}

pub fn cbrt(x: f64) -> f64 {
    libm::cbrt(x)
}

/// `(sin x, cos x)`.
pub fn sin_cos(x: f64) -> (f64, f64) {
    libm::sincos(x)
}

pub fn sin(x: f64) -> f64 {
    libm::sin(x)
}

pub fn atan(x: f64) -> f64 {
    libm::atan(x)
}

pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}
