//! View file-name patterns (`--pattern`).
//!
//! A pattern is a file name with placeholders in braces:
//! - `{row}` and `{col}`: the view's grid row and column, or
//! - `{index}`: the view's row-major index (`row · cols + col`).
//!
//! A placeholder may carry a width, `{row:02}` (or `{row:2}`): then it matches exactly
//! that many digits and missing names are shown zero-padded to it; without a width it
//! matches a run of digits. Everything else is literal text, compared exactly.
//! Indices may start at 0 or 1: the smallest index found decides (see `scene`).
//! Examples: `input_Cam{index:03}.png`, `2067_{row:02}_{col:02}.png`, `view{index}.png`.

use super::IoError;

/// What a placeholder stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    /// Grid row.
    Row,
    /// Grid column.
    Col,
    /// Row-major view index.
    Index,
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum Token {
    Literal(String),
    Field { field: Field, width: Option<usize> },
}

/// A parsed file-name pattern.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Pattern {
    tokens: Vec<Token>,
    text: String,
}

/// The numbers a file name carries.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Numbers {
    /// `{row}`, when the pattern has it.
    pub row: Option<usize>,
    /// `{col}`, when the pattern has it.
    pub col: Option<usize>,
    /// `{index}`, when the pattern has it.
    pub index: Option<usize>,
    /// The fewest digits any placeholder matched (0 when unknown).
    pub digits: usize,
}

fn bad(text: &str, why: &str) -> IoError {
    IoError::format(format!(
        "pattern `{text}` {why}: use e.g. `input_Cam{{index:03}}.png` or `NAME_{{row:02}}_{{col:02}}.png`"
    ))
}

impl Pattern {
    /// Parses a pattern; it must hold `{index}`, or both `{row}` and `{col}`.
    pub fn parse(text: &str) -> Result<Self, IoError> {
        let mut tokens = Vec::new();
        let mut rest = text;
        while !rest.is_empty() {
            match rest.find('{') {
                Some(0) => {
                    let Some(close) = rest.find('}') else {
                        return Err(bad(text, "has a `{` without its `}`"));
                    };
                    let inner = &rest[1..close];
                    let (name, width) = match inner.split_once(':') {
                        Some((name, w)) => {
                            let width: usize = w
                                .parse()
                                .ok()
                                .filter(|&w| (1..=9).contains(&w))
                                .ok_or_else(|| {
                                    bad(text, "has a width that is not 1 to 9 digits")
                                })?;
                            (name, Some(width))
                        }
                        None => (inner, None),
                    };
                    let field = match name {
                        "row" => Field::Row,
                        "col" => Field::Col,
                        "index" => Field::Index,
                        _ => {
                            return Err(bad(
                                text,
                                "names an unknown placeholder (use row, col, index)",
                            ))
                        }
                    };
                    if let Some(Token::Field { width: None, .. }) = tokens.last() {
                        return Err(bad(
                            text,
                            "has two placeholders in a row, the first without a width",
                        ));
                    }
                    tokens.push(Token::Field { field, width });
                    rest = &rest[close + 1..];
                }
                found => {
                    let end = found.unwrap_or(rest.len());
                    let literal = &rest[..end];
                    if literal.contains('}') {
                        return Err(bad(text, "has a `}` without its `{`"));
                    }
                    if literal.contains('/') || literal.contains('\\') {
                        return Err(bad(text, "must be a file name, not a path"));
                    }
                    tokens.push(Token::Literal(literal.to_string()));
                    rest = &rest[end..];
                }
            }
        }
        let has = |f: Field| {
            tokens
                .iter()
                .filter(|t| matches!(t, Token::Field { field, .. } if *field == f))
                .count()
        };
        let (rows, cols, indices) = (has(Field::Row), has(Field::Col), has(Field::Index));
        let valid =
            (rows == 1 && cols == 1 && indices == 0) || (rows == 0 && cols == 0 && indices == 1);
        if !valid {
            return Err(bad(
                text,
                "must hold `{index}` once, or `{row}` and `{col}` once each",
            ));
        }
        Ok(Pattern {
            tokens,
            text: text.to_string(),
        })
    }

    /// The pattern as written.
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// Whether views are numbered by a single index.
    pub fn uses_index(&self) -> bool {
        self.tokens.iter().any(|t| {
            matches!(
                t,
                Token::Field {
                    field: Field::Index,
                    ..
                }
            )
        })
    }

    /// The numbers in `name`, or `None` when it does not fit the pattern.
    pub fn matches(&self, name: &str) -> Option<Numbers> {
        let mut rest = name;
        let mut numbers = Numbers::default();
        for token in &self.tokens {
            match token {
                Token::Literal(literal) => rest = rest.strip_prefix(literal.as_str())?,
                Token::Field { field, width } => {
                    let run = rest.bytes().take_while(u8::is_ascii_digit).count();
                    let take = match width {
                        Some(w) if run >= *w => *w,
                        Some(_) => return None,
                        None if run > 0 => run,
                        None => return None,
                    };
                    // More than 9 digits cannot be a view number; refusing them also
                    // keeps the parse from overflowing.
                    if take > 9 {
                        return None;
                    }
                    let value: usize = rest[..take].parse().ok()?;
                    numbers.digits = if numbers.digits == 0 {
                        take
                    } else {
                        numbers.digits.min(take)
                    };
                    rest = &rest[take..];
                    let slot = match field {
                        Field::Row => &mut numbers.row,
                        Field::Col => &mut numbers.col,
                        Field::Index => &mut numbers.index,
                    };
                    *slot = Some(value);
                }
            }
        }
        rest.is_empty().then_some(numbers)
    }

    /// The file name of a view; `digits` pads placeholders without a width.
    pub fn render(&self, numbers: Numbers, digits: usize) -> String {
        let mut out = String::new();
        for token in &self.tokens {
            match token {
                Token::Literal(l) => out.push_str(l),
                Token::Field { field, width } => {
                    let value = match field {
                        Field::Row => numbers.row,
                        Field::Col => numbers.col,
                        Field::Index => numbers.index,
                    }
                    .unwrap_or(0);
                    let w = width.unwrap_or(digits);
                    out.push_str(&format!("{value:0w$}"));
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn row_col_with_widths() {
        let p = Pattern::parse("2067_{row:02}_{col:02}.png").unwrap();
        assert_eq!(
            p.matches("2067_03_11.png"),
            Some(Numbers {
                row: Some(3),
                col: Some(11),
                index: None,
                digits: 2
            })
        );
        assert_eq!(p.matches("2067_3_11.png"), None);
        assert_eq!(p.matches("2067_03_11.png.bak"), None);
        let n = p.matches("2067_01_09.png").unwrap();
        assert_eq!(p.render(n, 1), "2067_01_09.png");
    }

    #[test]
    fn index_without_width() {
        let p = Pattern::parse("view{index}.png").unwrap();
        assert!(p.uses_index());
        assert_eq!(p.matches("view0123.png").unwrap().index, Some(123));
        assert_eq!(p.matches("view.png"), None);
        assert_eq!(
            p.render(
                Numbers {
                    index: Some(7),
                    ..Numbers::default()
                },
                3
            ),
            "view007.png"
        );
    }

    #[test]
    fn malformed_patterns() {
        for bad in [
            "x.png",
            "{row}.png",
            "{row}{col}.png",
            "{row:0}_{col}.png",
            "{index",
            "a}{index}",
            "{idx}",
            "dir/{index}.png",
            "{index}_{row}_{col}",
        ] {
            assert!(Pattern::parse(bad).is_err(), "{bad}");
        }
        assert!(Pattern::parse("{row:2}{col:2}.png").is_ok());
    }
}
