//! Tokenizer of the pbrt scene format: quoted strings (with pbrt's backslash escapes), `[` and `]`,
//! `#` comments to the end of the line, and bare words (directive names, numbers, `true`/`false`).
//! Every token carries its 1-based line so that errors name the file and the line.

use crate::error::{Error, Location, Result};
use std::path::{Path, PathBuf};

/// The text of a file's bytes; invalid UTF-8 becomes U+FFFD (copied only then).
pub(crate) fn text_of(bytes: Vec<u8>) -> String {
    String::from_utf8(bytes).unwrap_or_else(|e| String::from_utf8_lossy(e.as_bytes()).into_owned())
}

/// What a token is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum TokenKind {
    /// A quoted string (the text is unquoted and unescaped).
    Str,
    /// A bare word: a directive name, a number, `true`/`false`.
    Bare,
    /// `[`.
    Open,
    /// `]`.
    Close,
}

/// One token with its line.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Token {
    /// Kind.
    pub kind: TokenKind,
    /// Text (unquoted for strings).
    pub text: String,
    /// 1-based line.
    pub line: usize,
}

impl Token {
    /// How the token reads in an error message.
    pub fn describe(&self) -> String {
        match self.kind {
            TokenKind::Str => format!("the string \"{}\"", self.text),
            TokenKind::Bare => format!("`{}`", self.text),
            TokenKind::Open => "`[`".into(),
            TokenKind::Close => "`]`".into(),
        }
    }
}

/// A tokenizer over the text of one file, with one token of look-ahead.
pub(crate) struct Tokenizer {
    text: String,
    pos: usize,
    line: usize,
    file: PathBuf,
    peeked: Option<Token>,
}

impl Tokenizer {
    /// Tokenize `text`, reporting locations in `file`.
    pub fn new(text: String, file: PathBuf) -> Self {
        Self {
            text,
            pos: 0,
            line: 1,
            file,
            peeked: None,
        }
    }

    /// The file the tokens come from.
    pub fn file(&self) -> &Path {
        &self.file
    }

    /// A location in this file.
    pub fn location(&self, line: usize) -> Location {
        Location {
            file: self.file.clone(),
            line,
        }
    }

    /// The last line of the file (for "unexpected end of file"); a final newline does not start
    /// a new line.
    pub fn end_location(&self) -> Location {
        let trailing = self.pos >= self.text.len() && self.text.ends_with('\n');
        self.location(if trailing { self.line - 1 } else { self.line }.max(1))
    }

    /// The next token without consuming it.
    pub fn peek(&mut self) -> Result<Option<&Token>> {
        if self.peeked.is_none() {
            self.peeked = self.scan()?;
        }
        Ok(self.peeked.as_ref())
    }

    /// The next token.
    pub fn next_token(&mut self) -> Result<Option<Token>> {
        match self.peeked.take() {
            Some(t) => Ok(Some(t)),
            None => self.scan(),
        }
    }

    fn scan(&mut self) -> Result<Option<Token>> {
        let bytes = self.text.as_bytes();
        loop {
            let Some(&c) = bytes.get(self.pos) else {
                return Ok(None);
            };
            match c {
                b'\n' => {
                    self.line += 1;
                    self.pos += 1;
                }
                b' ' | b'\t' | b'\r' | 0x0b | 0x0c => self.pos += 1,
                b'#' => {
                    while self.pos < bytes.len() && bytes[self.pos] != b'\n' {
                        self.pos += 1;
                    }
                }
                b'[' | b']' => {
                    self.pos += 1;
                    let (kind, text) = if c == b'[' {
                        (TokenKind::Open, "[")
                    } else {
                        (TokenKind::Close, "]")
                    };
                    return Ok(Some(Token {
                        kind,
                        text: text.into(),
                        line: self.line,
                    }));
                }
                b'"' => return self.scan_string().map(Some),
                _ => {
                    let start = self.pos;
                    while self.pos < bytes.len() {
                        let b = bytes[self.pos];
                        if b.is_ascii_whitespace() || matches!(b, b'"' | b'[' | b']' | b'#') {
                            break;
                        }
                        self.pos += 1;
                    }
                    // Delimiters are ASCII, so `start..pos` lies on character boundaries.
                    return Ok(Some(Token {
                        kind: TokenKind::Bare,
                        text: self.text[start..self.pos].to_string(),
                        line: self.line,
                    }));
                }
            }
        }
    }

    fn scan_string(&mut self) -> Result<Token> {
        let line = self.line;
        self.pos += 1; // opening quote
        let mut out = String::new();
        let mut chars = self.text[self.pos..].char_indices();
        while let Some((i, c)) = chars.next() {
            match c {
                '"' => {
                    self.pos += i + 1;
                    return Ok(Token {
                        kind: TokenKind::Str,
                        text: out,
                        line,
                    });
                }
                '\n' => {
                    return Err(Error::scene(
                        &self.location(line),
                        "unterminated string (a string may not span lines)",
                    ));
                }
                '\\' => {
                    let escaped = match chars.next() {
                        Some((_, 'b')) => '\u{8}',
                        Some((_, 'f')) => '\u{c}',
                        Some((_, 'n')) => '\n',
                        Some((_, 'r')) => '\r',
                        Some((_, 't')) => '\t',
                        Some((_, e @ ('\\' | '\'' | '"'))) => e,
                        Some((_, e)) => {
                            return Err(Error::scene(
                                &self.location(line),
                                format!("unknown escape sequence `\\{e}` in a string"),
                            ));
                        }
                        None => break,
                    };
                    out.push(escaped);
                }
                c => out.push(c),
            }
        }
        Err(Error::scene(
            &self.location(line),
            "unterminated string at the end of the file",
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all(text: &str) -> Vec<(TokenKind, String, usize)> {
        let mut t = Tokenizer::new(text.into(), "t.pbrt".into());
        let mut out = Vec::new();
        while let Some(tok) = t.next_token().unwrap() {
            out.push((tok.kind, tok.text, tok.line));
        }
        out
    }

    #[test]
    fn splits_brackets_strings_comments_and_counts_lines() {
        let toks = all("Shape \"tri\\\"x\" # comment [ ]\n[0 1.5e-007]\"a\"\n\n]");
        use TokenKind::*;
        assert_eq!(
            toks,
            vec![
                (Bare, "Shape".into(), 1),
                (Str, "tri\"x".into(), 1),
                (Open, "[".into(), 2),
                (Bare, "0".into(), 2),
                (Bare, "1.5e-007".into(), 2),
                (Close, "]".into(), 2),
                (Str, "a".into(), 2),
                (Close, "]".into(), 4),
            ]
        );
    }

    #[test]
    fn file_bytes_become_text_with_invalid_utf8_replaced() {
        assert_eq!(text_of(b"Shape \"sphere\"".to_vec()), "Shape \"sphere\"");
        assert_eq!(
            text_of(b"# caf\xe9\nWorldBegin".to_vec()),
            "# caf\u{fffd}\nWorldBegin"
        );
    }

    #[test]
    fn unterminated_strings_are_errors_with_their_line() {
        let mut t = Tokenizer::new("\n\"abc\nx\"".into(), "t.pbrt".into());
        let e = t.next_token().unwrap_err().to_string();
        assert!(e.contains("t.pbrt:2") && e.contains("unterminated"), "{e}");
        let mut t = Tokenizer::new("\"abc".into(), "t.pbrt".into());
        assert!(t.next_token().is_err());
    }
}
