//! Text handling shared by the readers: header lines over raw bytes, and fast line and token
//! iteration over ASCII data (validated as UTF-8 once, so tokens parse without re-checking).

use super::Fault;

/// Lines of a byte buffer with their 1-based numbers and their start offsets; a trailing `\r` is
/// removed (files written on Windows).
pub(crate) struct Lines<'a> {
    rest: &'a [u8],
    offset: usize,
    number: usize,
}

impl<'a> Lines<'a> {
    /// Lines of `data`, which starts at line `first_number` and byte `offset` of the file.
    pub fn new(data: &'a [u8], first_number: usize, offset: usize) -> Self {
        Self { rest: data, offset, number: first_number }
    }

    /// Byte offset in the file of the next line not yet returned.
    pub fn offset(&self) -> usize {
        self.offset
    }

    /// Number of the next line not yet returned.
    pub fn number(&self) -> usize {
        self.number
    }
}

impl<'a> Iterator for Lines<'a> {
    /// `(line number, line without its terminator)`.
    type Item = (usize, &'a [u8]);

    fn next(&mut self) -> Option<Self::Item> {
        if self.rest.is_empty() {
            return None;
        }
        let (line, consumed) = match self.rest.iter().position(|&b| b == b'\n') {
            Some(end) => (&self.rest[..end], end + 1),
            None => (self.rest, self.rest.len()),
        };
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        let number = self.number;
        self.rest = &self.rest[consumed..];
        self.offset += consumed;
        self.number += 1;
        Some((number, line))
    }
}

/// Lines of ASCII data (UTF-8 validated once up front) with 1-based numbers; a trailing `\r` is
/// removed.
pub(crate) struct TextLines<'a> {
    rest: &'a str,
    number: usize,
    /// True when the data stopped early at a byte that is not UTF-8.
    invalid: bool,
}

impl<'a> TextLines<'a> {
    /// Lines of `data`, whose first line is line `first_number` of the file. Only the UTF-8
    /// prefix is read; running past it is reported by [`TextLines::ran_out`].
    pub fn new(data: &'a [u8], first_number: usize) -> Self {
        let (rest, invalid) = match std::str::from_utf8(data) {
            Ok(text) => (text, false),
            Err(e) => {
                let valid = data.get(..e.valid_up_to()).and_then(|d| std::str::from_utf8(d).ok());
                (valid.unwrap_or_default(), true)
            }
        };
        Self { rest, number: first_number, invalid }
    }

    /// Bytes not yet returned.
    pub fn remaining(&self) -> usize {
        self.rest.len()
    }

    /// Number of the next line not yet returned.
    pub fn number(&self) -> usize {
        self.number
    }

    /// True when every byte of the file has been returned (a short last line is truncation).
    pub fn at_end(&self) -> bool {
        self.rest.is_empty() && !self.invalid
    }

    /// The error for data that ended before the reader had what it needed: `problem`, or that
    /// the data is not text when that is why it ended.
    pub fn ran_out(&self, problem: String) -> Fault {
        match self.invalid {
            true => Fault::line(self.number, "ascii data is not valid UTF-8 text"),
            false => Fault::line(self.number, problem),
        }
    }
}

impl<'a> Iterator for TextLines<'a> {
    /// `(line number, line without its terminator)`.
    type Item = (usize, &'a str);

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        if self.rest.is_empty() {
            return None;
        }
        let (line, rest) = self.rest.split_once('\n').unwrap_or((self.rest, ""));
        self.rest = rest;
        let number = self.number;
        self.number += 1;
        Some((number, line.strip_suffix('\r').unwrap_or(line)))
    }
}

/// Splits `line` at ASCII whitespace into `out` (cleared first), reusing its allocation.
#[inline]
pub(crate) fn tokenize<'a>(line: &'a str, out: &mut Vec<&'a str>) {
    // A plain byte loop: about twice as fast as `split_ascii_whitespace` + `extend` here.
    out.clear();
    let bytes = line.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        while i < bytes.len() && bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        let start = i;
        while i < bytes.len() && !bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        // Both ends sit next to ASCII bytes (or the line's ends), so they are char boundaries.
        if let Some(token) = line.get(start..i).filter(|t| !t.is_empty()) {
            out.push(token);
        }
    }
}

/// Parses one ASCII token as f32 (`nan`, `inf` and exponents accepted, as C's `strtof` writes).
#[inline]
pub(crate) fn parse_f32(token: &str) -> Result<f32, String> {
    token.parse::<f32>().map_err(|_| format!("'{}' is not a number", shown(token)))
}

/// A token for an error message: at most 40 characters.
pub(crate) fn shown(token: &str) -> String {
    match token.char_indices().nth(40) {
        Some((cut, _)) => format!("{}...", &token[..cut]),
        None => token.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_split_at_any_ascii_whitespace() {
        let mut out = Vec::new();
        tokenize("  1.5\t-2 \x0c nan\r", &mut out);
        assert_eq!(out, ["1.5", "-2", "nan"]);
        tokenize("", &mut out);
        assert!(out.is_empty());
        tokenize("é x\u{a0}y", &mut out);
        assert_eq!(out, ["é", "x\u{a0}y"], "only ASCII whitespace separates");
    }

    #[test]
    fn text_lines_number_lines_and_stop_at_invalid_utf8() {
        let mut lines = TextLines::new(b"a\r\nb\n\nc", 7);
        let all: Vec<_> = lines.by_ref().collect();
        assert_eq!(all, [(7, "a"), (8, "b"), (9, ""), (10, "c")]);
        assert!(lines.at_end());
        let mut lines = TextLines::new(b"a\nb\xff\n", 1);
        assert_eq!(lines.by_ref().collect::<Vec<_>>(), [(1, "a"), (2, "b")]);
        assert!(!lines.at_end());
        assert!(lines.ran_out("x".into()).problem.contains("UTF-8"));
    }
}
