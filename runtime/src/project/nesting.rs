//! A bound on how deeply a project file nests its collections, checked before the YAML reader
//! sees the text.
//!
//! The YAML reader (libyaml, under yaml_serde) keeps one "possible simple key" per open flow
//! collection and walks all of them for every token, so 100 000 nested brackets (a 200 KB
//! file) cost it 10¹⁰ steps: minutes before any answer. yaml_serde's own recursion limit (128)
//! applies only after the whole text has been scanned. A project needs a handful of levels, so
//! [`check`] refuses more than [`MAX_DEPTH`], at the collection that goes past it, in one pass.
//!
//! To find that collection exactly where libyaml would, the pass follows libyaml's scanner
//! (`scanner.c`: `fetch_next_token` and the scalar scanners) as far as nesting goes: which
//! character starts which token, where quoted, plain and block scalars end (a bracket inside
//! one is text), the flow level, and the indentation stack of block collections (simple keys
//! roll it at `:`, `-` and `?` roll it, a less indented token unrolls it). Where libyaml
//! would stop with a syntax error, the pass stops too and lets the reader report it.

/// The deepest nesting accepted: block and flow collections inside one another.
pub const MAX_DEPTH: usize = 64;

/// Where the text first nests deeper than [`MAX_DEPTH`]: 1-based line and column (in
/// characters) of the collection that does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct TooDeep {
    /// 1-based line.
    pub line: usize,
    /// 1-based column, in characters.
    pub column: usize,
}

/// Checks that `text` nests no deeper than [`MAX_DEPTH`]. Linear in the length of `text`.
pub(crate) fn check(text: &str) -> Result<(), TooDeep> {
    let mut s = Scanner::new(text.as_bytes());
    s.run()
}

/// A position: byte offset, 0-based line and column (characters), character index.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct Mark {
    at: usize,
    line: usize,
    column: usize,
    index: usize,
}

/// The scan stopped: at a collection too deep, or where libyaml reports a syntax error (`None`).
type Stop = Option<TooDeep>;

struct Scanner<'a> {
    b: &'a [u8],
    m: Mark,
    /// Open flow collections.
    flow: usize,
    /// The current block indentation (-1: none) and the enclosing ones.
    indent: i64,
    indents: Vec<i64>,
    simple_key_allowed: bool,
    /// The possible simple key of the block context (flow level 0), which rolls the indentation
    /// when its `:` comes; flow-level keys never do, so they are not tracked.
    key: Option<Mark>,
}

impl<'a> Scanner<'a> {
    fn new(b: &'a [u8]) -> Self {
        Self {
            b,
            m: Mark::default(),
            flow: 0,
            indent: -1,
            indents: Vec::new(),
            simple_key_allowed: true,
            key: None,
        }
    }

    fn run(&mut self) -> Result<(), TooDeep> {
        match self.tokens() {
            Ok(()) | Err(None) => Ok(()),
            Err(Some(deep)) => Err(deep),
        }
    }

    // --- characters ---

    fn at(&self, k: usize) -> u8 {
        self.b.get(self.m.at + k).copied().unwrap_or(0)
    }

    fn eof(&self) -> bool {
        self.m.at >= self.b.len()
    }

    /// Length in bytes of the line break at offset `k` from here (0: none). libyaml's breaks:
    /// CR LF, CR, LF, NEL, LS, PS.
    fn break_len(&self, k: usize) -> usize {
        match (self.at(k), self.at(k + 1), self.at(k + 2)) {
            (b'\r', b'\n', _) => 2,
            (b'\r' | b'\n', _, _) => 1,
            (0xC2, 0x85, _) => 2,
            (0xE2, 0x80, 0xA8 | 0xA9) => 3,
            _ => 0,
        }
    }

    fn is_break(&self, k: usize) -> bool {
        self.break_len(k) > 0
    }

    fn is_blank(&self, k: usize) -> bool {
        matches!(self.at(k), b' ' | b'\t')
    }

    /// A blank, a break or the end of the text.
    fn is_blankz(&self, k: usize) -> bool {
        self.is_blank(k) || self.is_break(k) || self.m.at + k >= self.b.len()
    }

    /// Moves past one character that is not a line break.
    fn skip(&mut self) {
        let lead = self.at(0);
        let width = match lead {
            0x00..=0x7F => 1,
            0xC0..=0xDF => 2,
            0xE0..=0xEF => 3,
            0xF0..=0xF7 => 4,
            _ => 1,
        };
        self.m.at = (self.m.at + width).min(self.b.len());
        self.m.column += 1;
        self.m.index += 1;
    }

    /// Moves past one line break (or one character when there is none).
    fn skip_line(&mut self) {
        let n = self.break_len(0);
        if n == 0 {
            self.skip();
            return;
        }
        self.m.at += n;
        self.m.line += 1;
        self.m.column = 0;
        self.m.index += 1;
    }

    // --- indentation, keys, depth ---

    fn depth_check(&self, at: Mark) -> Result<(), Stop> {
        if self.flow + self.indents.len() > MAX_DEPTH {
            return Err(Some(TooDeep {
                line: at.line + 1,
                column: at.column + 1,
            }));
        }
        Ok(())
    }

    fn roll_indent(&mut self, column: usize, at: Mark) -> Result<(), Stop> {
        if self.flow > 0 {
            return Ok(());
        }
        let column = i64::try_from(column).unwrap_or(i64::MAX);
        if self.indent < column {
            self.indents.push(self.indent);
            self.indent = column;
            self.depth_check(at)?;
        }
        Ok(())
    }

    fn unroll_indent(&mut self, column: i64) {
        if self.flow > 0 {
            return;
        }
        while self.indent > column {
            self.indent = self.indents.pop().unwrap_or(-1);
        }
    }

    fn save_simple_key(&mut self) {
        if self.flow == 0 && self.simple_key_allowed {
            self.key = Some(self.m);
        }
    }

    fn remove_simple_key(&mut self) {
        if self.flow == 0 {
            self.key = None;
        }
    }

    /// A saved key that can no longer be one (libyaml: on another line, or over 1024
    /// characters back).
    fn stale_simple_keys(&mut self) {
        if let Some(k) = self.key {
            if k.line < self.m.line || k.index + 1024 < self.m.index {
                self.key = None;
            }
        }
    }

    // --- tokens ---

    fn tokens(&mut self) -> Result<(), Stop> {
        loop {
            self.skip_to_next_token();
            self.stale_simple_keys();
            self.unroll_indent(i64::try_from(self.m.column).unwrap_or(i64::MAX));
            if self.eof() {
                return Ok(());
            }
            let c = self.at(0);
            let column0 = self.m.column == 0;
            let marker = |x: u8| self.at(0) == x && self.at(1) == x && self.at(2) == x;
            if column0 && c == b'%' {
                // A directive: its line.
                while !self.eof() && !self.is_break(0) {
                    self.skip();
                }
                continue;
            }
            if column0 && (marker(b'-') || marker(b'.')) && self.is_blankz(3) {
                self.unroll_indent(-1);
                self.remove_simple_key();
                self.simple_key_allowed = false;
                for _ in 0..3 {
                    self.skip();
                }
                continue;
            }
            match c {
                b'[' | b'{' => {
                    let at = self.m;
                    self.save_simple_key();
                    self.flow += 1;
                    self.depth_check(at)?;
                    self.simple_key_allowed = true;
                    self.skip();
                }
                b']' | b'}' => {
                    self.remove_simple_key();
                    self.flow = self.flow.saturating_sub(1);
                    self.simple_key_allowed = false;
                    self.skip();
                }
                b',' => {
                    self.remove_simple_key();
                    self.simple_key_allowed = true;
                    self.skip();
                }
                b'-' if self.is_blankz(1) => {
                    if self.flow == 0 {
                        if !self.simple_key_allowed {
                            return Err(None);
                        }
                        self.roll_indent(self.m.column, self.m)?;
                    }
                    self.remove_simple_key();
                    self.simple_key_allowed = true;
                    self.skip();
                }
                b'?' if self.flow > 0 || self.is_blankz(1) => {
                    if self.flow == 0 {
                        if !self.simple_key_allowed {
                            return Err(None);
                        }
                        self.roll_indent(self.m.column, self.m)?;
                    }
                    self.remove_simple_key();
                    self.simple_key_allowed = self.flow == 0;
                    self.skip();
                }
                b':' if self.flow > 0 || self.is_blankz(1) => self.value()?,
                b'*' | b'&' => {
                    self.save_simple_key();
                    self.simple_key_allowed = false;
                    self.anchor()?;
                }
                b'!' => {
                    self.save_simple_key();
                    self.simple_key_allowed = false;
                    self.tag()?;
                }
                b'|' | b'>' if self.flow == 0 => {
                    self.remove_simple_key();
                    self.simple_key_allowed = true;
                    self.block_scalar()?;
                }
                b'\'' | b'"' => {
                    self.save_simple_key();
                    self.simple_key_allowed = false;
                    self.flow_scalar(c == b'\'')?;
                }
                _ if self.starts_plain(c) => {
                    self.save_simple_key();
                    self.simple_key_allowed = false;
                    self.plain_scalar()?;
                }
                // libyaml: "found character that cannot start any token".
                _ => return Err(None),
            }
        }
    }

    /// libyaml's `scan_to_next_token`: blanks, comments and line breaks.
    fn skip_to_next_token(&mut self) {
        loop {
            if self.m.column == 0 && self.b.get(self.m.at..self.m.at + 3) == Some(b"\xEF\xBB\xBF") {
                self.m.at += 3;
            }
            while self.at(0) == b' '
                || ((self.flow > 0 || !self.simple_key_allowed) && self.at(0) == b'\t')
            {
                self.skip();
            }
            if self.at(0) == b'#' {
                while !self.eof() && !self.is_break(0) {
                    self.skip();
                }
            }
            if !self.is_break(0) {
                return;
            }
            self.skip_line();
            if self.flow == 0 {
                self.simple_key_allowed = true;
            }
        }
    }

    fn starts_plain(&self, c: u8) -> bool {
        let indicator = matches!(
            c,
            b'-' | b'?'
                | b':'
                | b','
                | b'['
                | b']'
                | b'{'
                | b'}'
                | b'#'
                | b'&'
                | b'*'
                | b'!'
                | b'|'
                | b'>'
                | b'\''
                | b'"'
                | b'%'
                | b'@'
                | b'`'
        );
        !(self.is_blankz(0) || indicator)
            || (c == b'-' && !self.is_blank(1))
            || (self.flow == 0 && matches!(c, b'?' | b':') && !self.is_blankz(1))
    }

    /// `:` — a value: a saved simple key becomes a block mapping's key.
    fn value(&mut self) -> Result<(), Stop> {
        let key = if self.flow == 0 {
            self.key.take()
        } else {
            None
        };
        match key {
            Some(key) => {
                self.roll_indent(key.column, key)?;
                self.simple_key_allowed = false;
            }
            None => {
                if self.flow == 0 {
                    if !self.simple_key_allowed {
                        return Err(None);
                    }
                    self.roll_indent(self.m.column, self.m)?;
                }
                self.simple_key_allowed = self.flow == 0;
            }
        }
        self.skip();
        Ok(())
    }

    /// `*alias` or `&anchor`: the indicator and its name.
    fn anchor(&mut self) -> Result<(), Stop> {
        self.skip();
        let mut length = 0;
        while self.at(0).is_ascii_alphanumeric() || matches!(self.at(0), b'_' | b'-') {
            self.skip();
            length += 1;
        }
        let ends = self.is_blankz(0)
            || matches!(
                self.at(0),
                b'?' | b':' | b',' | b']' | b'}' | b'%' | b'@' | b'`'
            );
        if length == 0 || !ends {
            return Err(None);
        }
        Ok(())
    }

    /// `!tag`, `!handle!suffix` or `!<verbatim>`.
    fn tag(&mut self) -> Result<(), Stop> {
        if self.at(1) == b'<' {
            self.skip();
            self.skip();
            self.uri_chars(true);
            if self.at(0) != b'>' {
                return Err(None);
            }
            self.skip();
        } else {
            // The handle (`!`, `!!` or `!word!`), then the suffix: both of URI characters.
            self.skip();
            while self.at(0).is_ascii_alphanumeric() || matches!(self.at(0), b'_' | b'-') {
                self.skip();
            }
            if self.at(0) == b'!' {
                self.skip();
            }
            self.uri_chars(false);
        }
        if !(self.is_blankz(0) || (self.flow > 0 && self.at(0) == b',')) {
            return Err(None);
        }
        Ok(())
    }

    /// libyaml's tag URI characters, `%` escapes among them; `,`, `[` and `]` only in a
    /// verbatim tag.
    fn uri_chars(&mut self, verbatim: bool) {
        while self.at(0).is_ascii_alphanumeric()
            || matches!(
                self.at(0),
                b'_' | b'-'
                    | b';'
                    | b'/'
                    | b'?'
                    | b':'
                    | b'@'
                    | b'&'
                    | b'='
                    | b'+'
                    | b'$'
                    | b'.'
                    | b'%'
                    | b'!'
                    | b'~'
                    | b'*'
                    | b'\''
                    | b'('
                    | b')'
            )
            || (verbatim && matches!(self.at(0), b',' | b'[' | b']'))
        {
            self.skip();
        }
    }

    /// `'...'` or `"..."`, over as many lines as it takes.
    fn flow_scalar(&mut self, single: bool) -> Result<(), Stop> {
        self.skip();
        loop {
            if self.m.column == 0
                && ((self.at(0) == b'-' && self.at(1) == b'-' && self.at(2) == b'-')
                    || (self.at(0) == b'.' && self.at(1) == b'.' && self.at(2) == b'.'))
                && self.is_blankz(3)
            {
                // libyaml: "found unexpected document indicator".
                return Err(None);
            }
            if self.eof() {
                // libyaml: "found unexpected end of stream".
                return Err(None);
            }
            match self.at(0) {
                b'\'' if single && self.at(1) == b'\'' => {
                    self.skip();
                    self.skip();
                }
                b'\'' if single => {
                    self.skip();
                    return Ok(());
                }
                b'"' if !single => {
                    self.skip();
                    return Ok(());
                }
                b'\\' if !single && self.is_break(1) => {
                    self.skip();
                    self.skip_line();
                }
                b'\\' if !single => {
                    self.skip();
                    if !self.eof() {
                        self.skip();
                    }
                }
                _ if self.is_break(0) => self.skip_line(),
                _ => self.skip(),
            }
        }
    }

    /// libyaml's `scan_plain_scalar`: where a plain scalar ends.
    fn plain_scalar(&mut self) -> Result<(), Stop> {
        let indent = self.indent + 1;
        let mut leading_blanks = false;
        loop {
            if self.m.column == 0
                && ((self.at(0) == b'-' && self.at(1) == b'-' && self.at(2) == b'-')
                    || (self.at(0) == b'.' && self.at(1) == b'.' && self.at(2) == b'.'))
                && self.is_blankz(3)
            {
                break;
            }
            if self.at(0) == b'#' {
                break;
            }
            while !self.is_blankz(0) {
                let c = self.at(0);
                if self.flow > 0
                    && c == b':'
                    && matches!(self.at(1), b',' | b'?' | b'[' | b']' | b'{' | b'}')
                {
                    // libyaml: "found unexpected ':'".
                    return Err(None);
                }
                if (c == b':' && self.is_blankz(1))
                    || (self.flow > 0 && matches!(c, b',' | b'[' | b']' | b'{' | b'}'))
                {
                    break;
                }
                self.skip();
            }
            if !(self.is_blank(0) || self.is_break(0)) {
                break;
            }
            while self.is_blank(0) || self.is_break(0) {
                if self.is_blank(0) {
                    self.skip();
                } else {
                    self.skip_line();
                    leading_blanks = true;
                }
            }
            if self.flow == 0 && i64::try_from(self.m.column).unwrap_or(i64::MAX) < indent {
                break;
            }
        }
        if leading_blanks {
            self.simple_key_allowed = true;
        }
        Ok(())
    }

    /// `|` or `>`: the header, then every line indented at least as the content.
    fn block_scalar(&mut self) -> Result<(), Stop> {
        self.skip();
        let mut increment = 0i64;
        for _ in 0..2 {
            match self.at(0) {
                b'+' | b'-' => self.skip(),
                d @ b'1'..=b'9' if increment == 0 => {
                    increment = i64::from(d - b'0');
                    self.skip();
                }
                b'0' => return Err(None),
                _ => {}
            }
        }
        while self.is_blank(0) {
            self.skip();
        }
        if self.at(0) == b'#' {
            while !self.eof() && !self.is_break(0) {
                self.skip();
            }
        }
        if !self.is_break(0) && !self.eof() {
            // libyaml: "did not find expected comment or line break".
            return Err(None);
        }
        if self.is_break(0) {
            self.skip_line();
        }
        let mut indent = if increment > 0 {
            if self.indent >= 0 {
                self.indent + increment
            } else {
                increment
            }
        } else {
            0
        };
        self.block_breaks(&mut indent);
        while i64::try_from(self.m.column).unwrap_or(i64::MAX) == indent && !self.eof() {
            while !self.eof() && !self.is_break(0) {
                self.skip();
            }
            if self.eof() {
                break;
            }
            self.skip_line();
            self.block_breaks(&mut indent);
        }
        Ok(())
    }

    /// libyaml's `scan_block_scalar_breaks`: the indentation of the lines ahead, fixing the
    /// content's indentation on the first that is not empty.
    fn block_breaks(&mut self, indent: &mut i64) {
        let mut max_indent = 0i64;
        loop {
            while (*indent == 0 || self.column() < *indent) && self.at(0) == b' ' {
                self.skip();
            }
            max_indent = max_indent.max(self.column());
            if !self.is_break(0) {
                break;
            }
            self.skip_line();
        }
        if *indent == 0 {
            *indent = max_indent.max(self.indent + 1).max(1);
        }
    }

    fn column(&self) -> i64 {
        i64::try_from(self.m.column).unwrap_or(i64::MAX)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn deep(text: &str) -> Option<(usize, usize)> {
        check(text).err().map(|d| (d.line, d.column))
    }

    #[test]
    fn flow_nesting_is_bounded_at_the_collection_past_the_limit() {
        let ok = format!(
            "x: {}{}\n",
            "[".repeat(MAX_DEPTH - 1),
            "]".repeat(MAX_DEPTH - 1)
        );
        // One block mapping (the root) and 63 flow levels: 64.
        assert_eq!(deep(&ok), None);
        let text = format!("x: {}{}\n", "[".repeat(MAX_DEPTH), "]".repeat(MAX_DEPTH));
        assert_eq!(deep(&text), Some((1, 4 + MAX_DEPTH - 1)));
        let braces = format!("a: 1\nb: {}\n", "{k: ".repeat(200));
        assert_eq!(deep(&braces), Some((2, 4 + 4 * (MAX_DEPTH - 1))));
    }

    #[test]
    fn block_nesting_counts_too() {
        let lines: String = (0..=MAX_DEPTH)
            .map(|i| format!("{}k{i}:\n", " ".repeat(i)))
            .collect();
        assert_eq!(deep(&lines), Some((MAX_DEPTH + 1, MAX_DEPTH + 1)));
        let dashes = format!("x:\n  {}a\n", "- ".repeat(MAX_DEPTH + 5));
        assert_eq!(deep(&dashes), Some((2, 3 + 2 * (MAX_DEPTH - 1))));
        // Indentation that comes back down closes what it leaves.
        let mut flat = String::new();
        for _ in 0..100 {
            flat.push_str("a:\n  b:\n    c: [1, {d: 2}]\n");
        }
        assert_eq!(deep(&flat), None);
    }

    #[test]
    fn brackets_in_scalars_and_comments_are_text() {
        let many = "[".repeat(500);
        for text in [
            format!("a: \"{many}\"\n"),
            format!("a: '{many}'\nb: 'it''s {many}'\n"),
            format!("a: x{many}\n"),
            format!("a: x # {many}\n"),
            format!("# {many}\na: 1\n"),
            format!("a: |\n  {many}\n  {many}\nb: 2\n"),
            format!("- a: >-\n    {many}\n\n    {many}\n  b: 3\n"),
            format!("a: \"x\\\"{many}\"\n"),
            format!("a: first line\n  continued {many}\n"),
            format!("a: [x, \"{many}\"]\n"),
        ] {
            assert_eq!(deep(&text), None, "{text}");
        }
    }

    #[test]
    fn what_ends_a_scalar_is_followed_as_libyaml_does() {
        let deepest = format!("{}{}", "[".repeat(100), "]".repeat(100));
        // After a block scalar the structure resumes: a sibling key less indented.
        let text = format!("- a: |\n    text\n  b: {deepest}\n");
        assert_eq!(deep(&text), Some((3, 5 + MAX_DEPTH - 1)));
        // A plain scalar that looks like a quote start does not hide what follows.
        let text = format!("a: it's\nb: {deepest}\nc: 'x'\n");
        assert_eq!(deep(&text), Some((2, 4 + MAX_DEPTH - 1)));
        // A ` #` inside quotes is not a comment.
        let text = format!("a: [\"x #\", {deepest}]\n");
        assert_eq!(deep(&text), Some((1, 11 + MAX_DEPTH - 1)));
        // Columns count characters, not bytes.
        let text = format!("é: {deepest}\n");
        assert_eq!(deep(&text), Some((1, 4 + MAX_DEPTH - 1)));
    }

    #[test]
    fn the_quick_start_and_odd_bytes_pass_or_stop_without_panicking() {
        let quickstart = include_str!("../../../examples/quickstart/project.yaml");
        assert_eq!(deep(quickstart), None);
        let mut state = 0x9e37_79b9_u32;
        let alphabet = b"[]{}:-?,'\"|>#&*!% \t\n\rab\\\xC2\x85\xE2\x80\xA8";
        for len in 0..400 {
            let bytes: Vec<u8> = (0..len)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 17;
                    state ^= state << 5;
                    alphabet[state as usize % alphabet.len()]
                })
                .collect();
            let text = String::from_utf8_lossy(&bytes);
            let _ = check(&text);
        }
    }
}
