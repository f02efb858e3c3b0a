//! The pbrt-v4 file syntax: tokens (words, quoted strings, numbers, brackets, `#` comments),
//! directives with their positional arguments and typed parameter lists
//! (`"float radius" 2`, `"rgb reflectance" [0.5 0.5 0.5]`), and `Include`/`Import` read in
//! place. Every error names the file and the line.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// How deep `Include`s may nest (a cycle is refused before that).
const MAX_INCLUDE_DEPTH: usize = 16;

#[derive(Clone, Debug, PartialEq)]
enum Token {
    Word(String),
    Str(String),
    Num(f64),
    Open,
    Close,
}

/// A value of a parameter or a positional argument.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Num(f64),
    Str(String),
}

/// One `"type name" value` of a parameter list.
#[derive(Clone, Debug)]
pub struct Param {
    pub ty: String,
    pub name: String,
    pub values: Vec<Value>,
}

/// A directive: its name, positional arguments (numbers and strings before the parameter
/// list), and parameters; `at` is "`file`: line L" for messages.
#[derive(Clone, Debug)]
pub struct Directive {
    pub name: String,
    pub args: Vec<Value>,
    pub params: Vec<Param>,
    pub at: String,
}

impl Directive {
    /// The error "`at`, `name`: `msg`".
    pub fn err(&self, msg: impl std::fmt::Display) -> Error {
        Error::new(format!("{}, {}: {msg}", self.at, self.name))
    }
}

/// Reads the directives of `text` (the file `file` in `dir`), `Include`s read in their place.
pub fn read(
    file: &str,
    dir: &Path,
    text: &str,
    included: &mut Vec<(PathBuf, Vec<u8>)>,
    depth: usize,
) -> Result<Vec<Directive>> {
    let tokens = tokenize(file, text)?;
    let mut out = Vec::new();
    let mut i = 0;
    while i < tokens.len() {
        let (line, tok) = &tokens[i];
        let at = format!("{file}: line {line}");
        let Token::Word(name) = tok else {
            return Err(Error::new(format!("{at}: expected a directive, got {}", shown(tok))));
        };
        i += 1;
        let mut args = Vec::new();
        // Positional arguments: numbers, strings, or one bracketed list of numbers
        // (`Transform [ … ]`), up to the first "type name" string of a parameter list.
        while i < tokens.len() {
            match &tokens[i].1 {
                Token::Num(v) => args.push(Value::Num(*v)),
                Token::Str(s) if !is_param_decl(s) => args.push(Value::Str(s.clone())),
                Token::Open if args.is_empty() && matches!(name.as_str(), "Transform" | "ConcatTransform") => {
                    i += 1;
                    while let Some((_, Token::Num(v))) = tokens.get(i) {
                        args.push(Value::Num(*v));
                        i += 1;
                    }
                    if tokens.get(i).map(|t| &t.1) != Some(&Token::Close) {
                        return Err(Error::new(format!("{at}, {name}: expected numbers and ]")));
                    }
                }
                _ => break,
            }
            i += 1;
        }
        let mut params = Vec::new();
        while let Some((pline, Token::Str(decl))) = tokens.get(i) {
            let Some((ty, pname)) = param_decl(decl) else { break };
            i += 1;
            let mut values = Vec::new();
            match tokens.get(i).map(|t| &t.1) {
                Some(Token::Open) => {
                    i += 1;
                    loop {
                        match tokens.get(i).map(|t| &t.1) {
                            Some(Token::Num(v)) => values.push(Value::Num(*v)),
                            Some(Token::Str(s)) => values.push(Value::Str(s.clone())),
                            Some(Token::Word(w)) if w == "true" || w == "false" => values.push(Value::Str(w.clone())),
                            Some(Token::Close) => break,
                            other => {
                                return Err(Error::new(format!(
                                    "{file}: line {pline}, {name}: parameter \"{decl}\": expected values and ], got {}",
                                    other.map_or("the end of the file".into(), shown)
                                )));
                            }
                        }
                        i += 1;
                    }
                }
                Some(Token::Num(v)) => values.push(Value::Num(*v)),
                Some(Token::Str(s)) => values.push(Value::Str(s.clone())),
                Some(Token::Word(w)) if w == "true" || w == "false" => values.push(Value::Str(w.clone())),
                other => {
                    return Err(Error::new(format!(
                        "{file}: line {pline}, {name}: parameter \"{decl}\": expected a value, got {}",
                        other.map_or("the end of the file".into(), shown)
                    )));
                }
            }
            i += 1;
            params.push(Param {
                ty: ty.to_string(),
                name: pname.to_string(),
                values,
            });
        }
        let d = Directive {
            name: name.clone(),
            args,
            params,
            at,
        };
        if matches!(name.as_str(), "Include" | "Import") {
            out.extend(include(&d, dir, included, depth)?);
        } else {
            out.push(d);
        }
    }
    Ok(out)
}

/// The directives of the file an `Include` names: relative to the directory of the scene's
/// main file (pbrt-v4's search directory, also for includes inside includes), gzip-compressed
/// when its name ends in `.gz`.
fn include(d: &Directive, dir: &Path, included: &mut Vec<(PathBuf, Vec<u8>)>, depth: usize) -> Result<Vec<Directive>> {
    let [Value::Str(name)] = &d.args[..] else {
        return Err(d.err("expected one file name"));
    };
    if depth >= MAX_INCLUDE_DEPTH {
        return Err(d.err(format!("includes nested deeper than {MAX_INCLUDE_DEPTH} (a cycle?)")));
    }
    let path = dir.join(name);
    let bytes = crate::util::read_input(&path, "included pbrt file", crate::util::MAX_TEXT_INPUT)
        .map_err(|e| d.err(format!("{name}: {e}")))?;
    let plain = if crate::util::is_gzip(&path) {
        crate::util::gunzip(&bytes, crate::util::MAX_TEXT_INPUT).map_err(|e| d.err(format!("{name}: {e}")))?
    } else {
        bytes.clone()
    };
    let text = std::str::from_utf8(&plain)
        .map_err(|_| d.err(format!("{name}: not valid UTF-8")))?
        .to_string();
    included.push((path.clone(), bytes));
    let shown = path.display().to_string();
    read(&shown, dir, &text, included, depth + 1)
}

/// Whether a string opens a parameter: "type name".
fn is_param_decl(s: &str) -> bool {
    param_decl(s).is_some()
}

/// The type and name of a parameter declaration "type name".
fn param_decl(s: &str) -> Option<(&str, &str)> {
    let mut words = s.split_whitespace();
    let (ty, name) = (words.next()?, words.next()?);
    words.next().is_none().then_some((ty, name))
}

fn shown(t: &Token) -> String {
    match t {
        Token::Word(w) => w.clone(),
        Token::Str(s) => format!("\"{s}\""),
        Token::Num(v) => v.to_string(),
        Token::Open => "[".into(),
        Token::Close => "]".into(),
    }
}

/// The tokens of `text`, each with its line.
fn tokenize(file: &str, text: &str) -> Result<Vec<(u32, Token)>> {
    let mut out = Vec::new();
    let mut chars = text.char_indices().peekable();
    let mut line = 1u32;
    while let Some(&(start, c)) = chars.peek() {
        match c {
            '\n' => {
                line += 1;
                chars.next();
            }
            c if c.is_whitespace() => {
                chars.next();
            }
            '#' => {
                while chars.peek().is_some_and(|&(_, c)| c != '\n') {
                    chars.next();
                }
            }
            '[' | ']' => {
                chars.next();
                out.push((line, if c == '[' { Token::Open } else { Token::Close }));
            }
            '"' => {
                chars.next();
                let first = line;
                let mut s = String::new();
                loop {
                    match chars.next() {
                        Some((_, '"')) => break,
                        Some((_, '\\')) => match chars.next() {
                            Some((_, 'n')) => s.push('\n'),
                            Some((_, 't')) => s.push('\t'),
                            Some((_, c)) => s.push(c),
                            None => break,
                        },
                        Some((_, '\n')) => {
                            return Err(Error::new(format!(
                                "{file}: line {first}: a string runs past the end of the line"
                            )));
                        }
                        Some((_, c)) => s.push(c),
                        None => {
                            return Err(Error::new(format!("{file}: line {first}: a string is not closed")));
                        }
                    }
                }
                out.push((line, Token::Str(s)));
            }
            _ => {
                let mut end = start;
                while let Some(&(i, c)) = chars.peek() {
                    if c.is_whitespace() || matches!(c, '[' | ']' | '"' | '#') {
                        break;
                    }
                    end = i + c.len_utf8();
                    chars.next();
                }
                let word = &text[start..end];
                let first = word.chars().next().unwrap_or(' ');
                if first.is_ascii_digit() || matches!(first, '-' | '+' | '.') {
                    let v: f64 = word
                        .parse()
                        .map_err(|_| Error::new(format!("{file}: line {line}: {word:?} is not a number")))?;
                    if !v.is_finite() {
                        return Err(Error::new(format!(
                            "{file}: line {line}: {word:?} is not a finite number"
                        )));
                    }
                    out.push((line, Token::Num(v)));
                } else if first.is_ascii_alphabetic() {
                    out.push((line, Token::Word(word.to_string())));
                } else {
                    return Err(Error::new(format!("{file}: line {line}: unexpected {word:?}")));
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Vec<Directive>> {
        read("t.pbrt", Path::new("."), text, &mut Vec::new(), 0)
    }

    #[test]
    fn directives_arguments_and_parameter_lists_are_read() {
        let d = parse(
            "# a comment\nLookAt 0 0 5  0 0 0   0 1 0\nTransform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]\n\
             Shape \"sphere\" \"float radius\" 2 \"rgb L\" [1 .5 0.25] \"bool x\" true\nWorldBegin",
        )
        .unwrap();
        assert_eq!(d.len(), 4);
        assert_eq!((d[0].name.as_str(), d[0].args.len()), ("LookAt", 9));
        assert_eq!(d[1].args.len(), 16);
        assert_eq!(d[2].args, vec![Value::Str("sphere".into())]);
        assert_eq!(d[2].params.len(), 3);
        assert_eq!((d[2].params[1].ty.as_str(), d[2].params[1].name.as_str()), ("rgb", "L"));
        assert_eq!(
            d[2].params[1].values,
            vec![Value::Num(1.0), Value::Num(0.5), Value::Num(0.25)]
        );
        assert_eq!(d[2].params[2].values, vec![Value::Str("true".into())]);
        assert!(d[2].at.ends_with("line 4"), "{}", d[2].at);
    }

    #[test]
    fn malformed_input_is_refused_naming_the_line() {
        for (text, expect) in [
            ("Shape \"sphere\"\n\"float radius\" [2", "line 2"),
            ("Shape \"sphere\" \"float radius\" 1e999", "finite"),
            ("[1 2]", "expected a directive"),
            ("Film \"rgb\" \"integer xresolution\" \"oops", "not closed"),
            ("Include \"no-such-file.pbrt\"", "no-such-file"),
        ] {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.contains(expect) && e.lines().count() == 1, "{text:?}: {e}");
        }
    }
}
