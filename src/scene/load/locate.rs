//! The first two stages of loading: TOML syntax and the serde model, with every error located
//! by key path and line/column (`shapes[3].radius: invalid type … (line 12, column 10)`).

use super::*;
use crate::error::Result;
use crate::scene::desc::{self, SceneDesc};
use serde::Deserialize;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// Parses the TOML and deserializes the model, turning byte spans into key paths and
/// line/column positions.
pub(super) fn parse_desc(ctx: &Ctx, text: &str) -> Result<SceneDesc> {
    let doc = DeTable::parse(text).map_err(|e| {
        let at = e
            .span()
            .map(|s| format!(" at {}", line_col(text, s.start)))
            .unwrap_or_default();
        ctx.whole(format!("TOML syntax error{at}: {}", e.message()))
    })?;
    let root = Spanned::new(doc.span(), DeValue::Table(doc.get_ref().clone()));
    let e = match SceneDesc::deserialize(toml::de::Deserializer::from(doc)) {
        Ok(desc) => return Ok(desc),
        Err(e) => e,
    };
    let Some(span) = e.span() else {
        return Err(ctx.whole(e.message()));
    };
    let mut path = Vec::new();
    find_path(&root, span.start, &mut path);
    let (path, message, pos) =
        refine_tagged(&root, &path).unwrap_or_else(|| (path, e.message().to_string(), span.start));
    let field = path_string(&path);
    let msg = format!("{message} ({})", line_col(text, pos));
    Err(if field.is_empty() {
        ctx.whole(msg)
    } else {
        ctx.err(&field, msg)
    })
}

/// One step of a key path.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Seg {
    Key(String),
    Index(usize),
}

pub(super) fn path_string(path: &[Seg]) -> String {
    let mut s = String::new();
    for seg in path {
        match seg {
            Seg::Key(k) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(&key_string(k));
            }
            Seg::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

/// A key as it would be written in TOML: bare when possible, quoted otherwise.
pub(super) fn key_string(k: &str) -> String {
    let bare = !k.is_empty() && k.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if bare { k.to_string() } else { format!("{k:?}") }
}

pub(super) fn line_col(text: &str, pos: usize) -> String {
    let before = text.get(..pos).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    format!("line {line}, column {col}")
}

pub(super) fn span_contains(span: std::ops::Range<usize>, pos: usize) -> bool {
    span.contains(&pos) || (span.is_empty() && span.start == pos)
}

/// Appends to `path` the keys leading to the deepest key or value whose span holds `pos`.
/// Tables of an array of tables (`[[shapes]]`) span only their header, so children are
/// searched even when their parent's span does not hold `pos`.
pub(super) fn find_path(v: &Spanned<DeValue>, pos: usize, path: &mut Vec<Seg>) -> bool {
    match v.get_ref() {
        DeValue::Table(t) => {
            for (k, val) in t.iter() {
                path.push(Seg::Key(k.get_ref().to_string()));
                if span_contains(k.span(), pos) {
                    return true;
                }
                if find_path(val, pos, path) || span_contains(val.span(), pos) {
                    return true;
                }
                path.pop();
            }
            false
        }
        DeValue::Array(a) => {
            for (i, item) in a.iter().enumerate() {
                path.push(Seg::Index(i));
                if find_path(item, pos, path) || span_contains(item.span(), pos) {
                    return true;
                }
                path.pop();
            }
            false
        }
        _ => false,
    }
}

pub(super) fn lookup<'a, 'i>(root: &'a Spanned<DeValue<'i>>, path: &[Seg]) -> Option<&'a Spanned<DeValue<'i>>> {
    let mut v = root;
    for seg in path {
        v = match (v.get_ref(), seg) {
            (DeValue::Table(t), Seg::Key(k)) => t.get(k.as_str())?,
            (DeValue::Array(a), Seg::Index(i)) => a.get(*i)?,
            _ => return None,
        };
    }
    Some(v)
}

/// serde deserializes an internally tagged enum (`type = "sphere"`) from a buffered copy of
/// the table, which loses positions: an error inside a shape or material points at the whole
/// `shapes` array or `materials` table, not even at the element. This deserializes each
/// element's variant struct again, straight from the document, which does carry positions, and
/// returns the key path, message and position of the first error found.
pub(super) fn refine_tagged(root: &Spanned<DeValue>, path: &[Seg]) -> Option<(Vec<Seg>, String, usize)> {
    let Some(Seg::Key(collection)) = path.first() else {
        return None;
    };
    // Deeper paths (e.g. `shapes[2].type` for an unknown type) are already precise.
    if !(collection == "shapes" || collection == "materials") || path.len() > 2 {
        return None;
    }
    let is_shape = collection == "shapes";
    let elements: Vec<(Seg, &Spanned<DeValue>)> = match lookup(root, &path[..1])?.get_ref() {
        DeValue::Array(a) => a.iter().enumerate().map(|(i, v)| (Seg::Index(i), v)).collect(),
        DeValue::Table(t) => t.iter().map(|(k, v)| (Seg::Key(k.get_ref().to_string()), v)).collect(),
        _ => return None,
    };
    for (seg, node) in elements {
        let at = vec![path[0].clone(), seg];
        let DeValue::Table(table) = node.get_ref() else {
            continue;
        };
        let Some(kind) = table.get("type") else {
            return Some((at, "missing field `type`".into(), node.span().start));
        };
        let Some(kind) = kind.get_ref().as_str() else {
            continue;
        };
        let mut inner = DeTable::new();
        for (k, v) in table.iter() {
            if k.get_ref() != "type" {
                inner.insert(k.clone(), v.clone());
            }
        }
        let value = Spanned::new(node.span(), DeValue::Table(inner));
        let de = toml::de::ValueDeserializer::from(value);
        let err = match (is_shape, kind) {
            (true, "quad") => desc::Quad::deserialize(de).err(),
            (true, "box") => desc::Cuboid::deserialize(de).err(),
            (true, "sphere") => desc::Sphere::deserialize(de).err(),
            (true, "mesh") => desc::Mesh::deserialize(de).err(),
            (true, "disk") => desc::Disk::deserialize(de).err(),
            (true, "cylinder") => desc::Cylinder::deserialize(de).err(),
            (false, "diffuse") => desc::Diffuse::deserialize(de).err(),
            (false, "mirror") => desc::Mirror::deserialize(de).err(),
            (false, "dielectric") => desc::Dielectric::deserialize(de).err(),
            (false, "phong") => desc::Phong::deserialize(de).err(),
            (false, "ward") => desc::Ward::deserialize(de).err(),
            (false, "diffuse_transmission") => desc::DiffuseTransmission::deserialize(de).err(),
            // serde itself reports unknown types, precisely, at the `type` value.
            _ => None,
        };
        let Some(err) = err else {
            continue;
        };
        let pos = err.span().map_or(node.span().start, |s| s.start);
        let mut refined = Vec::new();
        find_path(root, pos, &mut refined);
        // Keep the refined path only if it lies inside this element.
        if !refined.starts_with(&at) {
            refined = at;
        }
        return Some((refined, err.message().to_string(), pos));
    }
    None
}
