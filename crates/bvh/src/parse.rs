//! The hand-written BVH parser.
//!
//! The HIERARCHY section is read as whitespace-separated tokens that remember their
//! 1-based line (braces may stand alone or stick to a word); `OFFSET` and `CHANNELS` take
//! the rest of their own line, and a joint's name is the rest of its keyword's line.
//! The MOTION section is read line by line: `Frames: N`, `Frame Time: dt`, then exactly
//! N lines of exactly `channel_count` numbers (blank lines are skipped). Both `\n` and
//! `\r\n` line ends are accepted, mixed.

use std::collections::HashSet;
use std::path::Path;

use crate::error::BvhError;
use crate::skeleton::{Bvh, Channel, Node};

/// How deep joints may nest. Real skeletons are 5–30 joints deep; the parser recurses per
/// level, so an absurd depth (a generated or corrupted file) is refused by this bound
/// instead of overflowing the stack.
pub const MAX_DEPTH: usize = 256;

/// The largest BVH file read: 1 GiB (an hour of 120 fps capture of a 60-joint skeleton
/// is about 300 MB of text).
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// Reads and parses a BVH file; errors name the file by its base name.
pub fn read(path: &Path) -> Result<Bvh, BvhError> {
    let file = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
    let bytes = reprise_artifact::input::read(path, MAX_FILE_BYTES)
        .map_err(|e| BvhError::Io { file: file.clone(), source: e.into_io() })?;
    parse(&file, &String::from_utf8_lossy(&bytes))
}

/// Parses BVH text; `file` names it in error messages.
pub fn parse(file: &str, text: &str) -> Result<Bvh, BvhError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let lines: Vec<&str> = text.lines().collect();
    let mut tokens = Vec::new();
    let mut motion_line = None;
    'lines: for (index, line) in lines.iter().enumerate() {
        for word in line.split_whitespace() {
            for token in split_braces(word) {
                tokens.push(Token { line: index + 1, text: token });
                if token == "MOTION" {
                    motion_line = Some(index + 1);
                    break 'lines;
                }
            }
        }
    }
    let mut parser =
        Parser { file, tokens, pos: 0, nodes: Vec::new(), columns: 0, names: HashSet::new(), eof_line: lines.len() };
    parser.hierarchy()?;
    let motion_line = motion_line.expect("the hierarchy parser only returns Ok at MOTION");
    let motion = read_motion(file, &lines, motion_line, parser.columns)?;
    Ok(Bvh {
        file: file.to_string(),
        nodes: parser.nodes,
        channel_count: parser.columns,
        frames: motion.frames,
        frame_time: motion.frame_time,
        frames_line: motion.frames_line,
        motion: motion.values,
    })
}

/// Splits `{` and `}` off a whitespace-separated word.
fn split_braces(word: &str) -> impl Iterator<Item = &str> {
    let mut rest = word;
    std::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        let cut = match rest.find(['{', '}']) {
            Some(0) => 1,
            Some(i) => i,
            None => rest.len(),
        };
        let (token, tail) = rest.split_at(cut);
        rest = tail;
        Some(token)
    })
}

#[derive(Clone, Copy)]
struct Token<'a> {
    line: usize,
    text: &'a str,
}

struct Parser<'a> {
    file: &'a str,
    tokens: Vec<Token<'a>>,
    pos: usize,
    nodes: Vec<Node>,
    columns: usize,
    names: HashSet<String>,
    eof_line: usize,
}

impl<'a> Parser<'a> {
    fn peek(&self) -> Option<Token<'a>> {
        self.tokens.get(self.pos).copied()
    }

    fn next(&mut self) -> Option<Token<'a>> {
        let token = self.peek();
        self.pos += 1;
        token
    }

    /// Line of a token, or the last line for the end of the file.
    fn line_of(&self, token: Option<Token>) -> usize {
        token.map_or(self.eof_line.max(1), |t| t.line)
    }

    fn syntax(&self, token: Option<Token>, expected: impl Into<String>) -> BvhError {
        BvhError::Syntax {
            file: self.file.to_string(),
            line: self.line_of(token),
            expected: expected.into(),
            found: describe(token),
        }
    }

    /// The remaining tokens on `line`, stopping at a brace.
    fn rest_of_line(&mut self, line: usize) -> Vec<&'a str> {
        let mut out = Vec::new();
        while let Some(token) = self.peek() {
            if token.line != line || token.text == "{" || token.text == "}" {
                break;
            }
            out.push(token.text);
            self.pos += 1;
        }
        out
    }

    fn unique_name(&mut self, base: &str) -> String {
        let mut name = base.to_string();
        let mut n = 2;
        while self.names.contains(&name) {
            name = format!("{base}#{n}");
            n += 1;
        }
        self.names.insert(name.clone());
        name
    }

    fn hierarchy(&mut self) -> Result<(), BvhError> {
        let first = self.next();
        if first.map(|t| t.text) != Some("HIERARCHY") {
            return Err(self.syntax(first, "`HIERARCHY` at the start of the file"));
        }
        let mut roots = 0;
        loop {
            let token = self.next();
            match token.map(|t| t.text) {
                Some("ROOT") => {
                    self.joint(None, token.expect("matched"), 1)?;
                    roots += 1;
                }
                Some("MOTION") if roots > 0 => return Ok(()),
                _ if roots == 0 => return Err(self.syntax(token, "`ROOT`")),
                _ => return Err(self.syntax(token, "`ROOT` or `MOTION`")),
            }
        }
    }

    /// Parses `<name> { … }` after ROOT or JOINT (the keyword token is `keyword`), at
    /// nesting `depth` (the root is 1; at most [`MAX_DEPTH`]).
    fn joint(&mut self, parent: Option<usize>, keyword: Token, depth: usize) -> Result<(), BvhError> {
        if depth > MAX_DEPTH {
            let message = format!("joints nest more than {MAX_DEPTH} deep; a `}}` is missing or the file is damaged");
            return Err(self.node_error(keyword.line, message));
        }
        let name = self.rest_of_line(keyword.line).join(" ");
        if name.is_empty() {
            return Err(self.syntax(self.peek(), format!("a joint name after `{}`", keyword.text)));
        }
        let what = format!("`{} {name}` (line {})", keyword.text, keyword.line);
        let open = self.next();
        if open.map(|t| t.text) != Some("{") {
            return Err(self.syntax(open, format!("`{{` after {what}")));
        }
        let index = self.nodes.len();
        let unique = self.unique_name(&name);
        self.nodes.push(Node {
            name: unique,
            parent,
            offset: [0.0; 3],
            channels: Vec::new(),
            first_column: self.columns,
            end_site: false,
            line: keyword.line,
        });
        let (mut has_offset, mut has_channels) = (false, false);
        loop {
            let token = self.next();
            match token.map(|t| t.text) {
                Some("OFFSET") if !has_offset => {
                    self.nodes[index].offset = self.offset(token.expect("matched"))?;
                    has_offset = true;
                }
                Some("CHANNELS") if !has_channels => {
                    self.channels(index, token.expect("matched"))?;
                    has_channels = true;
                }
                Some("OFFSET" | "CHANNELS") => {
                    let t = token.expect("matched");
                    return Err(self.node_error(t.line, format!("second {} in {what}", t.text)));
                }
                Some("JOINT") => self.joint(Some(index), token.expect("matched"), depth + 1)?,
                Some("End") => self.end_site(index, token.expect("matched"))?,
                Some("}") if has_offset => return Ok(()),
                Some("}") => return Err(self.node_error(self.line_of(token), format!("{what} has no OFFSET"))),
                _ => {
                    let expected = format!("`OFFSET`, `CHANNELS`, `JOINT`, `End Site` or `}}` closing {what}");
                    return Err(self.syntax(token, expected));
                }
            }
        }
    }

    /// Parses `Site { OFFSET x y z }` after `End`.
    fn end_site(&mut self, parent: usize, keyword: Token) -> Result<(), BvhError> {
        let site = self.next();
        if site.map(|t| (t.text, t.line)) != Some(("Site", keyword.line)) {
            return Err(self.syntax(site, "`Site` after `End`"));
        }
        let what = format!("`End Site` (line {})", keyword.line);
        let open = self.next();
        if open.map(|t| t.text) != Some("{") {
            return Err(self.syntax(open, format!("`{{` after {what}")));
        }
        let token = self.next();
        let offset = match token {
            Some(t) if t.text == "OFFSET" => self.offset(t)?,
            _ => {
                let message = format!("{what} must hold exactly one OFFSET, found {}", describe(token));
                return Err(self.node_error(self.line_of(token), message));
            }
        };
        let close = self.next();
        if close.map(|t| t.text) != Some("}") {
            let message = format!("{what} must hold only an OFFSET; expected `}}`, found {}", describe(close));
            return Err(self.node_error(self.line_of(close), message));
        }
        let name = self.unique_name(&format!("{}.end", self.nodes[parent].name));
        self.nodes.push(Node {
            name,
            parent: Some(parent),
            offset,
            channels: Vec::new(),
            first_column: self.columns,
            end_site: true,
            line: keyword.line,
        });
        Ok(())
    }

    fn node_error(&self, line: usize, message: String) -> BvhError {
        BvhError::Node { file: self.file.to_string(), line, message }
    }

    fn offset(&mut self, keyword: Token) -> Result<[f64; 3], BvhError> {
        let words = self.rest_of_line(keyword.line);
        let error = |found: String| BvhError::Offset { file: self.file.to_string(), line: keyword.line, found };
        if words.len() != 3 {
            return Err(error(format!("{} ({})", count(words.len(), "value"), quote_all(&words))));
        }
        let mut offset = [0.0; 3];
        for (slot, word) in offset.iter_mut().zip(&words) {
            *slot = parse_number(word).ok_or_else(|| error(format!("`{word}`, which is not a number")))?;
        }
        Ok(offset)
    }

    fn channels(&mut self, node: usize, keyword: Token) -> Result<(), BvhError> {
        let words = self.rest_of_line(keyword.line);
        let file = self.file.to_string();
        let line = keyword.line;
        let Some((declared, names)) = words.split_first() else {
            return Err(self.syntax(self.peek(), "a channel count after `CHANNELS`"));
        };
        let count_error = || BvhError::ChannelCount {
            file: file.clone(),
            line,
            declared: declared.to_string(),
            named: names.len(),
            names: if names.is_empty() { "none".to_string() } else { names.join(" ") },
        };
        let declared_count: usize = declared.parse().map_err(|_| count_error())?;
        if declared_count != names.len() {
            return Err(count_error());
        }
        let mut channels = Vec::with_capacity(names.len());
        for name in names {
            let channel = Channel::from_name(name).ok_or_else(|| BvhError::UnknownChannel {
                file: file.clone(),
                line,
                name: name.to_string(),
            })?;
            if !channel.is_rotation() && channels.contains(&channel) {
                let joint = self.nodes[node].name.clone();
                return Err(BvhError::DuplicateChannel { file, line, name: name.to_string(), joint });
            }
            channels.push(channel);
        }
        self.nodes[node].first_column = self.columns;
        self.nodes[node].channels = channels;
        self.columns += names.len();
        Ok(())
    }
}

fn describe(token: Option<Token>) -> String {
    token.map_or_else(|| "the end of the file".to_string(), |t| format!("`{}`", t.text))
}

fn count(n: usize, what: &str) -> String {
    if n == 1 {
        format!("1 {what}")
    } else {
        format!("{n} {what}s")
    }
}

fn quote_all(words: &[&str]) -> String {
    if words.is_empty() {
        "nothing".to_string()
    } else {
        words.iter().map(|w| format!("`{w}`")).collect::<Vec<_>>().join(" ")
    }
}

/// A finite number, or `None`.
fn parse_number(word: &str) -> Option<f64> {
    word.parse::<f64>().ok().filter(|v| v.is_finite())
}

struct Motion {
    frames: usize,
    frame_time: f64,
    frames_line: usize,
    values: Vec<f64>,
}

/// Reads the MOTION section, which starts on the line after `motion_line` (1-based).
fn read_motion(file: &str, lines: &[&str], motion_line: usize, columns: usize) -> Result<Motion, BvhError> {
    let last_line = lines.len().max(1);
    // (1-based line number, trimmed text) of the non-blank lines after MOTION.
    let mut rest =
        lines.iter().enumerate().skip(motion_line).map(|(i, l)| (i + 1, l.trim())).filter(|(_, l)| !l.is_empty());
    let excerpt = |text: &str| {
        let short: String = text.chars().take(60).collect();
        if short.len() < text.len() {
            format!("`{short}…`")
        } else {
            format!("`{short}`")
        }
    };

    let (frames_line, frames) = match rest.next() {
        Some((line, text)) => {
            let count = text.strip_prefix("Frames:").and_then(|v| v.trim().parse::<usize>().ok());
            let found = excerpt(text);
            (line, count.ok_or_else(|| BvhError::Frames { file: file.to_string(), line, found })?)
        }
        None => {
            return Err(BvhError::Frames {
                file: file.to_string(),
                line: last_line,
                found: "the end of the file".into(),
            })
        }
    };
    let frame_time = match rest.next() {
        Some((line, text)) => {
            let time = text.strip_prefix("Frame Time:").and_then(|v| parse_number(v.trim())).filter(|&v| v > 0.0);
            let found = excerpt(text);
            time.ok_or_else(|| BvhError::FrameTime { file: file.to_string(), line, found })?
        }
        None => {
            return Err(BvhError::FrameTime {
                file: file.to_string(),
                line: last_line,
                found: "the end of the file".into(),
            })
        }
    };

    // Reserve for the lines that are there, not for the count the file declares (a typo
    // there must not allocate gigabytes before the count check below refuses it).
    let present = lines.len().saturating_sub(motion_line);
    let mut values = Vec::with_capacity(frames.min(present).saturating_mul(columns));
    let mut read = 0;
    for (line, text) in rest {
        if read == frames {
            let found = format!("line {line} is motion line {}, one more than declared", frames + 1);
            return Err(BvhError::FrameCount { file: file.to_string(), line, frames_line, declared: frames, found });
        }
        let start = values.len();
        for (column, word) in text.split_whitespace().enumerate() {
            let value = parse_number(word).ok_or_else(|| BvhError::Number {
                file: file.to_string(),
                line,
                column: column + 1,
                text: word.to_string(),
            })?;
            values.push(value);
        }
        let found = values.len() - start;
        if found != columns {
            return Err(BvhError::ValueCount { file: file.to_string(), line, found, expected: columns });
        }
        read += 1;
    }
    if read < frames {
        let found = format!("the file ends after {}", count(read, "motion line"));
        return Err(BvhError::FrameCount {
            file: file.to_string(),
            line: last_line,
            frames_line,
            declared: frames,
            found,
        });
    }
    Ok(Motion { frames, frame_time, frames_line, values })
}
