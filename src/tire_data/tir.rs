//! MF-Tyre / Pacejka tire property files (`.tir`): sections in brackets, `KEY = value`
//! lines, `$` starting a comment, `!` lines as comments, `{` lines opening a table whose
//! rows are numbers without a key, quoted strings. Keys are case-insensitive; sections the
//! mapping does not read are kept but not interpreted.

use std::fmt;

/// A value of a `KEY = value` line.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Number(f64),
    Text(String),
}

/// One `KEY = value` line: the key as written, its section and its line number (from 1).
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    pub key: String,
    pub section: String,
    pub value: Value,
    pub line: usize,
}

/// A parsed property file: its entries in file order.
#[derive(Clone, Debug, PartialEq)]
pub struct TirFile {
    pub entries: Vec<Entry>,
}

/// Why a file cannot be read, with the line it is on.
#[derive(Clone, Debug, PartialEq)]
pub struct SyntaxError {
    pub line: usize,
    pub message: String,
}

impl fmt::Display for SyntaxError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

impl std::error::Error for SyntaxError {}

/// The part of a line before its `$` comment, outside quotes.
fn without_comment(line: &str) -> &str {
    let mut quote = None;
    for (i, c) in line.char_indices() {
        match (quote, c) {
            (None, '\'' | '"') => quote = Some(c),
            (Some(q), c) if c == q => quote = None,
            (None, '$') => return &line[..i],
            _ => {}
        }
    }
    line
}

impl TirFile {
    pub fn parse(text: &str) -> Result<TirFile, SyntaxError> {
        let mut entries = Vec::new();
        let mut section = String::new();
        for (index, raw) in text.lines().enumerate() {
            let line = index + 1;
            let error = |message: String| SyntaxError { line, message };
            let content = without_comment(raw).trim();
            if content.is_empty() || content.starts_with('!') || content.starts_with('{') {
                continue;
            }
            if let Some(rest) = content.strip_prefix('[') {
                let name = rest
                    .strip_suffix(']')
                    .ok_or_else(|| error(format!("section header '{content}' has no closing ']'")))?;
                section = name.trim().to_ascii_uppercase();
                continue;
            }
            let Some((key, value)) = content.split_once('=') else {
                // A row of a table: numbers only.
                if content.split_whitespace().all(|word| word.parse::<f64>().is_ok()) {
                    continue;
                }
                return Err(error(format!(
                    "'{content}' is neither a section, a KEY = value line, a comment nor a table row"
                )));
            };
            let key = key.trim();
            if key.is_empty() || key.contains(char::is_whitespace) {
                return Err(error(format!("'{key}' is not a key")));
            }
            let value = value.trim();
            let value = if let Some(text) = quoted(value) {
                Value::Text(text.to_owned())
            } else {
                let number = value
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| {
                        error(format!(
                            "{key} = '{value}' is neither a number nor a quoted string"
                        ))
                    })?;
                Value::Number(number)
            };
            entries.push(Entry {
                key: key.to_owned(),
                section: section.clone(),
                value,
                line,
            });
        }
        Ok(TirFile { entries })
    }

    /// The last entry with this key (any case), in any section.
    pub fn entry(&self, key: &str) -> Option<&Entry> {
        self.entries
            .iter()
            .rev()
            .find(|e| e.key.eq_ignore_ascii_case(key))
    }

    /// The number of key `key`, if the file has one; an error if the key holds text.
    pub fn number(&self, key: &str) -> Result<Option<(f64, &Entry)>, SyntaxError> {
        match self.entry(key) {
            None => Ok(None),
            Some(
                entry @ Entry {
                    value: Value::Number(v),
                    ..
                },
            ) => Ok(Some((*v, entry))),
            Some(entry) => Err(SyntaxError {
                line: entry.line,
                message: format!("{} must be a number", entry.key),
            }),
        }
    }

    /// The text of key `key`, if the file has one as a quoted string.
    pub fn text(&self, key: &str) -> Option<&str> {
        match self.entry(key) {
            Some(Entry {
                value: Value::Text(t),
                ..
            }) => Some(t),
            _ => None,
        }
    }

    /// Whether the file has a section of this name (any case).
    pub fn has_section(&self, name: &str) -> bool {
        self.entries.iter().any(|e| e.section.eq_ignore_ascii_case(name))
    }
}

/// The text inside matching single or double quotes.
fn quoted(value: &str) -> Option<&str> {
    ['\'', '"']
        .into_iter()
        .find_map(|q| value.strip_prefix(q).and_then(|rest| rest.strip_suffix(q)))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SAMPLE: &str = "\
[MDI_HEADER]
FILE_TYPE                ='tir'
FILE_VERSION             = 3.0
! : COMMENT : a comment line
$----------------------------------------------------------------units
[units]
length                   ='meter'   $ a trailing comment
[DIMENSION]
UNLOADED_RADIUS          = 0.3135  $Free tyre radius
[SHAPE]
{radial width}
 1.0    0.0
 1.0    0.4
[LATERAL_COEFFICIENTS]
pky1                     = -21.92  $Maximum value of stiffness Kfy/Fznom
PKY2 = 2.0e0
NOTE = \"a $ inside quotes\"
";

    #[test]
    fn reads_keys_in_any_case_past_comments_and_tables() {
        let file = TirFile::parse(SAMPLE).unwrap();
        assert_eq!(file.text("file_type"), Some("tir"));
        assert_eq!(file.number("PKY1").unwrap().unwrap().0, -21.92);
        let (value, entry) = file.number("Pky2").unwrap().unwrap();
        assert_eq!(
            (value, entry.line, entry.section.as_str()),
            (2.0, 16, "LATERAL_COEFFICIENTS")
        );
        assert_eq!(file.text("NOTE"), Some("a $ inside quotes"));
        assert_eq!(file.text("LENGTH"), Some("meter"));
        assert!(file.has_section("dimension"));
        assert_eq!(file.number("PKY3").unwrap(), None);
        assert!(file.number("FILE_TYPE").is_err());
    }

    #[test]
    fn a_bad_line_is_named_by_its_number() {
        let error = TirFile::parse("[MDI_HEADER]\nFILE_TYPE = 'tir'\nPKY1 = 1.2.3\n").unwrap_err();
        assert_eq!(error.line, 3);
        assert!(error.message.contains("PKY1 = '1.2.3'"), "{error}");
        let error = TirFile::parse("[MODEL\n").unwrap_err();
        assert_eq!(error.line, 1);
        let error = TirFile::parse("just words\n").unwrap_err();
        assert!(error.to_string().starts_with("line 1:"), "{error}");
    }
}
