//! The tag scanner of the `.vtu` reader: elements, attributes, comments, processing
//! instructions and character data of the XML part of the file (the appended block is raw
//! bytes, not XML). No entities, no namespaces.

use super::super::text::short;

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Kind {
    Start,
    End,
    Empty,
}

/// One tag: its name, attributes and byte range in the text.
#[derive(Debug)]
pub(super) struct Tag<'a> {
    pub(super) name: &'a str,
    pub(super) attrs: Vec<(&'a str, &'a str)>,
    pub(super) kind: Kind,
    pub(super) start: usize,
    pub(super) end: usize,
}

impl<'a> Tag<'a> {
    pub(super) fn attr(&self, key: &str) -> Option<&'a str> {
        self.attrs.iter().find(|(k, _)| *k == key).map(|(_, v)| *v)
    }
}

/// Every tag of `text` in order; an error gives the byte offset and the reason.
pub(super) fn scan(text: &str) -> Result<Vec<Tag<'_>>, (usize, String)> {
    let mut tags = Vec::new();
    let b = text.as_bytes();
    let mut i = 0;
    while let Some(off) = text[i..].find('<') {
        let s = i + off;
        let rest = &text[s..];
        let skip_to = |pat: &str| {
            rest.find(pat).map(|e| s + e + pat.len()).ok_or((
                s,
                format!(
                    "unclosed '{}'",
                    short(&rest.chars().take(9).collect::<String>())
                ),
            ))
        };
        if rest.starts_with("<!--") {
            i = skip_to("-->")?;
            continue;
        }
        if rest.starts_with("<![CDATA[") {
            i = skip_to("]]>")?;
            continue;
        }
        if rest.starts_with("<?") {
            i = skip_to("?>")?;
            continue;
        }
        if rest.starts_with("<!") {
            i = skip_to(">")?;
            continue;
        }
        let (kind0, mut j) = if rest.starts_with("</") {
            (Kind::End, s + 2)
        } else {
            (Kind::Start, s + 1)
        };
        let name_start = j;
        while j < b.len() && !b[j].is_ascii_whitespace() && b[j] != b'>' && b[j] != b'/' {
            j += 1;
        }
        let name = &text[name_start..j];
        if name.is_empty() {
            return Err((s, "a tag without a name".into()));
        }
        let mut attrs = Vec::new();
        let mut kind = kind0;
        loop {
            while j < b.len() && b[j].is_ascii_whitespace() {
                j += 1;
            }
            if j >= b.len() {
                return Err((s, format!("unclosed tag <{}", short(name))));
            }
            if b[j] == b'>' {
                j += 1;
                break;
            }
            if b[j] == b'/' && kind == Kind::Start && b.get(j + 1) == Some(&b'>') {
                kind = Kind::Empty;
                j += 2;
                break;
            }
            let k0 = j;
            while j < b.len() && b[j] != b'=' && !b[j].is_ascii_whitespace() && b[j] != b'>' {
                j += 1;
            }
            let key = &text[k0..j];
            while j < b.len() && b[j].is_ascii_whitespace() {
                j += 1;
            }
            if j >= b.len() || b[j] != b'=' {
                return Err((k0, format!("attribute '{}' without a value", short(key))));
            }
            j += 1;
            while j < b.len() && b[j].is_ascii_whitespace() {
                j += 1;
            }
            let q = match b.get(j) {
                Some(&q) if q == b'"' || q == b'\'' => q,
                _ => return Err((k0, format!("attribute '{}' value not quoted", short(key)))),
            };
            let v0 = j + 1;
            let Some(len) = text[v0..].find(q as char) else {
                return Err((k0, format!("attribute '{}' value not closed", short(key))));
            };
            attrs.push((key, &text[v0..v0 + len]));
            j = v0 + len + 1;
        }
        tags.push(Tag {
            name,
            attrs,
            kind,
            start: s,
            end: j,
        });
        i = j;
    }
    Ok(tags)
}
