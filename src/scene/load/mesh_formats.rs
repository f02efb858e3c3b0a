//! Triangle meshes from files other than OBJ: Stanford PLY (ASCII and binary, through the
//! `ply-rs-bw` crate) and Mitsuba's `.serialized` format; and Mitsuba's smooth vertex normals
//! for meshes that have none.
//!
//! Every parser returns [`TriMesh`]es or a message saying what is wrong with the file; the
//! caller adds the file name. Counts are checked against the bytes actually present before
//! anything is allocated, so a hostile header cannot ask for gigabytes.

use glam::{DVec2, DVec3};
use std::io::Read;

/// One mesh as read from a file: positions, optional per-vertex normals and texture
/// coordinates (v already as Mitsuba 3.9.1 reads it: flipped for OBJ only), triangles.
#[derive(Debug, Default)]
pub(super) struct TriMesh {
    pub(super) name: String,
    pub(super) positions: Vec<DVec3>,
    pub(super) normals: Option<Vec<DVec3>>,
    pub(super) uvs: Option<Vec<DVec2>>,
    pub(super) triangles: Vec<[usize; 3]>,
    /// Mitsuba's mesh attributes (`vertex_color`, `face_color`, …), what a `mesh_attribute`
    /// texture reads.
    pub(super) attributes: Vec<MeshAttr>,
}

/// One mesh attribute as Mitsuba 3.9.1's PLY reader names it: the properties `NAME_0`,
/// `NAME_1`, … of element `vertex` (or `face`) become attribute `vertex_NAME` (`face_NAME`)
/// with one channel each; `r`, `g`, `b` (or `red`, `green`, `blue`), with `a` (`alpha`) if
/// present, become `vertex_color` (`face_color`) unless `NAME_k` properties already gave it.
/// Values are taken as they are (Mitsuba warns about 8-bit colours but does not divide them by
/// 255). Other properties are ignored, as Mitsuba ignores them.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct MeshAttr {
    pub(super) name: String,
    pub(super) channels: usize,
    /// Per vertex; a face attribute per triangle (a polygon's value repeated for each of the
    /// triangles fanned from it).
    pub(super) per_face: bool,
    /// `channels` values per vertex or triangle.
    pub(super) values: Vec<f32>,
}

/// The attributes of one PLY element (`vertex` or `face`: `prefix`), each as a list of
/// property names, in Mitsuba's naming (see [`MeshAttr`]).
fn ply_attribute_groups(properties: &[String], prefix: &str) -> Vec<(String, Vec<String>)> {
    let mut groups: Vec<(String, Vec<String>)> = Vec::new();
    for name in properties {
        let Some((base, k)) = name.rsplit_once('_') else {
            continue;
        };
        let Ok(k) = k.parse::<usize>() else {
            continue;
        };
        let attribute = format!("{prefix}_{base}");
        match groups.iter_mut().find(|(a, _)| *a == attribute) {
            Some((_, props)) if props.len() == k => props.push(name.clone()),
            Some(_) => {}
            None if k == 0 => groups.push((attribute, vec![name.clone()])),
            None => {}
        }
    }
    let color = format!("{prefix}_color");
    if !groups.iter().any(|(a, _)| *a == color) {
        for names in [["r", "g", "b", "a"], ["red", "green", "blue", "alpha"]] {
            if names[..3].iter().all(|n| properties.iter().any(|p| p == n)) {
                let n = if properties.iter().any(|p| p == names[3]) { 4 } else { 3 };
                groups.push((color, names[..n].iter().map(|s| s.to_string()).collect()));
                break;
            }
        }
    }
    groups
}

/// A Stanford PLY file: element `vertex` with `x`, `y`, `z` (and `nx`, `ny`, `nz` if all three
/// are present; texture coordinates `u`, `v` or `s`, `t` or `texture_u`, `texture_v`, taken as
/// they are, as Mitsuba 3.9.1 does — its development version flips v as for OBJ), element `face` with a list property `vertex_indices` (or `vertex_index`);
/// polygons are fanned from their first corner, as Mitsuba does.
pub(super) fn parse_ply(bytes: &[u8]) -> Result<TriMesh, String> {
    use ply_rs_bw::parser::Parser;
    use ply_rs_bw::ply::{DefaultElement, Property};
    let parser = Parser::<DefaultElement>::new();
    // The parser is not ours: a panic on a malformed file becomes an error.
    let ply = std::panic::catch_unwind(|| parser.read_ply(&mut &bytes[..]))
        .map_err(|_| "the PLY parser failed".to_string())?
        .map_err(|e| format!("not a valid PLY file: {e}"))?;
    let vertices = ply.payload.get("vertex").ok_or("no `vertex` element")?;
    let faces = ply.payload.get("face").ok_or("no `face` element")?;
    let scalar = |e: &DefaultElement, key: &str| e.get(key).and_then(Property::to_f32_lossy).map(f64::from);
    let mut positions = Vec::with_capacity(vertices.len());
    for (i, v) in vertices.iter().enumerate() {
        let (Some(x), Some(y), Some(z)) = (scalar(v, "x"), scalar(v, "y"), scalar(v, "z")) else {
            return Err(format!("vertex {i} lacks a numeric x, y or z"));
        };
        positions.push(DVec3::new(x, y, z));
    }
    let normals = vertices
        .iter()
        .map(|v| Some(DVec3::new(scalar(v, "nx")?, scalar(v, "ny")?, scalar(v, "nz")?)))
        .collect::<Option<Vec<_>>>()
        .filter(|n| !n.is_empty());
    let uvs = [("u", "v"), ("s", "t"), ("texture_u", "texture_v")]
        .iter()
        .find_map(|(ku, kv)| {
            vertices
                .iter()
                .map(|v| Some(DVec2::new(scalar(v, ku)?, scalar(v, kv)?)))
                .collect::<Option<Vec<_>>>()
                .filter(|uv| !uv.is_empty())
        });
    let property_names = |element: &str| -> Vec<String> {
        ply.header
            .elements
            .get(element)
            .map_or_else(Vec::new, |e| e.properties.keys().cloned().collect())
    };
    let vertex_groups = ply_attribute_groups(&property_names("vertex"), "vertex");
    let face_groups = ply_attribute_groups(&property_names("face"), "face");
    let mut attributes = Vec::new();
    for (name, props) in &vertex_groups {
        let mut values = Vec::with_capacity(props.len() * vertices.len());
        for (i, v) in vertices.iter().enumerate() {
            for p in props {
                let x = v.get(p).and_then(Property::to_f32_lossy);
                values.push(x.ok_or_else(|| format!("vertex {i} lacks a number `{p}` (attribute {name})"))?);
            }
        }
        attributes.push(MeshAttr {
            name: name.clone(),
            channels: props.len(),
            per_face: false,
            values,
        });
    }
    let mut face_values: Vec<Vec<f32>> = vec![Vec::new(); face_groups.len()];
    let mut triangles = Vec::with_capacity(faces.len());
    for (i, f) in faces.iter().enumerate() {
        let list = f.get("vertex_indices").or_else(|| f.get("vertex_index"));
        let corners: Vec<i64> = match list {
            Some(Property::ListChar(l)) => l.iter().map(|&x| i64::from(x)).collect(),
            Some(Property::ListUChar(l)) => l.iter().map(|&x| i64::from(x)).collect(),
            Some(Property::ListShort(l)) => l.iter().map(|&x| i64::from(x)).collect(),
            Some(Property::ListUShort(l)) => l.iter().map(|&x| i64::from(x)).collect(),
            Some(Property::ListInt(l)) => l.iter().map(|&x| i64::from(x)).collect(),
            Some(Property::ListUInt(l)) => l.iter().map(|&x| i64::from(x)).collect(),
            _ => return Err(format!("face {i} has no integer list `vertex_indices`")),
        };
        if corners.len() < 3 {
            return Err(format!("face {i} has {} corners (at least 3 expected)", corners.len()));
        }
        let index = |k: i64| -> Result<usize, String> {
            usize::try_from(k)
                .ok()
                .filter(|&k| k < positions.len())
                .ok_or_else(|| format!("face {i} refers to vertex {k}, but there are {}", positions.len()))
        };
        for k in 1..corners.len() - 1 {
            triangles.push([index(corners[0])?, index(corners[k])?, index(corners[k + 1])?]);
        }
        for ((name, props), values) in face_groups.iter().zip(&mut face_values) {
            let face: Vec<f32> = props
                .iter()
                .map(|p| f.get(p).and_then(Property::to_f32_lossy))
                .collect::<Option<_>>()
                .ok_or_else(|| format!("face {i} lacks a number for attribute {name}"))?;
            for _ in 1..corners.len() - 1 {
                values.extend_from_slice(&face);
            }
        }
    }
    for ((name, props), values) in face_groups.into_iter().zip(face_values) {
        attributes.push(MeshAttr {
            name,
            channels: props.len(),
            per_face: true,
            values,
        });
    }
    Ok(TriMesh {
        name: String::new(),
        positions,
        normals,
        uvs,
        triangles,
        attributes,
    })
}

/// Flags of a `.serialized` mesh (Mitsuba 0.6's `TriMesh::EFlags`, kept by Mitsuba 3).
const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const FACE_NORMALS: u32 = 0x0010;
const SINGLE_PRECISION: u32 = 0x1000;
const DOUBLE_PRECISION: u32 = 0x2000;

/// Shape `shape_index` of a Mitsuba `.serialized` file: a sequence of meshes, each a 16-bit
/// format tag 0x041C, a 16-bit version (3 or 4) and a zlib stream of flags, name (version 4),
/// vertex and triangle counts, positions, then normals, texture coordinates and colours as the
/// flags say, then the triangles' indices (32-bit, or 64-bit beyond 2³² vertices); little
/// endian throughout. The file ends with each mesh's byte offset (64-bit in version 4, 32-bit
/// in version 3) and the number of meshes (32-bit). Returns the mesh and whether it asks for
/// face normals.
pub(super) fn parse_serialized(bytes: &[u8], shape_index: u32) -> Result<(TriMesh, bool), String> {
    if bytes.len() < 8 {
        return Err("too short for a Mitsuba .serialized file".to_string());
    }
    let u16_at = |at: usize| u16::from_le_bytes([bytes[at], bytes[at + 1]]);
    if u16_at(0) != 0x041C {
        return Err("not a Mitsuba .serialized file (no 0x041C format tag)".to_string());
    }
    let version = u16_at(2);
    if !(version == 3 || version == 4) {
        return Err(format!("unsupported .serialized version {version} (3 or 4 expected)"));
    }
    let count = u32::from_le_bytes(bytes[bytes.len() - 4..].try_into().expect("4 bytes"));
    if shape_index >= count {
        return Err(format!(
            "shape_index {shape_index} is out of range: the file holds {count} meshes"
        ));
    }
    let offset_size = if version == 4 { 8 } else { 4 };
    let table = (count as usize)
        .checked_mul(offset_size)
        .and_then(|t| bytes.len().checked_sub(4 + t))
        .ok_or("the table of mesh offsets does not fit in the file")?;
    let at = table + shape_index as usize * offset_size;
    let offset = if version == 4 {
        u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes")) as usize
    } else {
        u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes")) as usize
    };
    if offset + 4 > table || u16_at(offset) != 0x041C || u16_at(offset + 2) != version {
        return Err(format!(
            "mesh {shape_index} does not start with the format tag at offset {offset}"
        ));
    }
    let mut stream = Vec::new();
    flate2::read::ZlibDecoder::new(&bytes[offset + 4..table])
        .take(crate::util::MAX_MESH_INPUT)
        .read_to_end(&mut stream)
        .map_err(|e| format!("mesh {shape_index}: the compressed data is corrupt: {e}"))?;
    let mut r = Cursor { data: &stream, at: 0 };
    let flags = r.u32()?;
    let name = if version == 4 { r.c_string()? } else { String::new() };
    let (vertices, triangles) = (r.u64()? as usize, r.u64()? as usize);
    let double = match (flags & SINGLE_PRECISION != 0, flags & DOUBLE_PRECISION != 0) {
        (true, false) => false,
        (false, true) => true,
        _ => return Err(format!("mesh {shape_index}: the flags name neither or both precisions")),
    };
    // Every array's size is checked against what is left before it is read.
    let mut reals = |n: usize| -> Result<Vec<f64>, String> {
        let bytes = n.checked_mul(if double { 8 } else { 4 }).ok_or("overflow")?;
        if bytes > r.remaining() {
            return Err(format!(
                "mesh {shape_index}: truncated (an array of {n} numbers does not fit)"
            ));
        }
        (0..n)
            .map(|_| if double { r.f64() } else { r.f32().map(f64::from) })
            .collect()
    };
    let to_vecs = |v: Vec<f64>| {
        v.chunks_exact(3)
            .map(|c| DVec3::new(c[0], c[1], c[2]))
            .collect::<Vec<_>>()
    };
    let positions = to_vecs(reals(vertices.checked_mul(3).ok_or("overflow")?)?);
    let normals = if flags & HAS_NORMALS != 0 {
        Some(to_vecs(reals(vertices * 3)?))
    } else {
        None
    };
    // Mitsuba keeps a .serialized file's v as it is.
    let uvs = if flags & HAS_TEXCOORDS != 0 {
        Some(
            reals(vertices * 2)?
                .chunks_exact(2)
                .map(|c| DVec2::new(c[0], c[1]))
                .collect(),
        )
    } else {
        None
    };
    // Mitsuba reads a .serialized file's vertex colours as the attribute `vertex_color`.
    let mut attributes = Vec::new();
    if flags & HAS_COLORS != 0 {
        attributes.push(MeshAttr {
            name: "vertex_color".to_string(),
            channels: 3,
            per_face: false,
            values: reals(vertices * 3)?.into_iter().map(|x| x as f32).collect(),
        });
    }
    let wide = vertices > u32::MAX as usize;
    let index_bytes = triangles.checked_mul(3 * if wide { 8 } else { 4 }).ok_or("overflow")?;
    if index_bytes > r.remaining() {
        return Err(format!(
            "mesh {shape_index}: truncated (the triangle indices do not fit)"
        ));
    }
    let mut tris = Vec::with_capacity(triangles);
    for t in 0..triangles {
        let mut tri = [0usize; 3];
        for corner in &mut tri {
            *corner = if wide { r.u64()? as usize } else { r.u32()? as usize };
            if *corner >= vertices {
                return Err(format!(
                    "mesh {shape_index}: triangle {t} refers to vertex {corner}, but there are {vertices}"
                ));
            }
        }
        tris.push(tri);
    }
    Ok((
        TriMesh {
            name,
            positions,
            normals,
            uvs,
            triangles: tris,
            attributes,
        },
        flags & FACE_NORMALS != 0,
    ))
}

/// A little-endian reader over decompressed bytes.
struct Cursor<'a> {
    data: &'a [u8],
    at: usize,
}

impl Cursor<'_> {
    fn remaining(&self) -> usize {
        self.data.len() - self.at
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let b = self
            .data
            .get(self.at..self.at + N)
            .ok_or("truncated mesh data")?
            .try_into()
            .expect("N bytes");
        self.at += N;
        Ok(b)
    }

    fn u32(&mut self) -> Result<u32, String> {
        self.take::<4>().map(u32::from_le_bytes)
    }

    fn u64(&mut self) -> Result<u64, String> {
        self.take::<8>().map(u64::from_le_bytes)
    }

    fn f32(&mut self) -> Result<f32, String> {
        self.take::<4>().map(f32::from_le_bytes)
    }

    fn f64(&mut self) -> Result<f64, String> {
        self.take::<8>().map(f64::from_le_bytes)
    }

    fn c_string(&mut self) -> Result<String, String> {
        let rest = &self.data[self.at..];
        let end = rest.iter().position(|&b| b == 0).ok_or("unterminated mesh name")?;
        self.at += end + 1;
        Ok(String::from_utf8_lossy(&rest[..end]).into_owned())
    }
}

/// Whether a mesh file of `kind` ("obj", "ply" or "serialized") carries vertex normals.
pub fn mesh_file_has_normals(bytes: &[u8], kind: &str, shape_index: Option<u32>) -> Result<bool, String> {
    Ok(match kind {
        "ply" => parse_ply(bytes)?.normals.is_some(),
        "serialized" => {
            let (mesh, flat) = parse_serialized(bytes, shape_index.unwrap_or(0))?;
            mesh.normals.is_some() && !flat
        }
        _ => bytes
            .split(|&b| b == b'\n')
            .any(|l| l.trim_ascii_start().starts_with(b"vn ")),
    })
}

/// Smooth vertex normals as Mitsuba 3 computes them for a mesh that has none: each triangle's
/// unit normal added to its three corners weighted by the corner's interior angle [Thürmer &
/// Wüthrich 1998, "Computing Vertex Normals from Polygonal Facets"], then normalised. A vertex
/// no triangle gives a normal to gets zero (the triangle then shades flat).
pub(super) fn angle_weighted_normals(positions: &[DVec3], triangles: &[[usize; 3]]) -> Vec<DVec3> {
    let mut normals = vec![DVec3::ZERO; positions.len()];
    for t in triangles {
        let p = t.map(|i| positions[i]);
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        if n == DVec3::ZERO {
            continue;
        }
        for k in 0..3 {
            let (d0, d1) = (
                (p[(k + 1) % 3] - p[k]).normalize_or_zero(),
                (p[(k + 2) % 3] - p[k]).normalize_or_zero(),
            );
            normals[t[k]] += n * d0.dot(d1).clamp(-1.0, 1.0).acos();
        }
    }
    normals.iter().map(|n| n.normalize_or_zero()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `.serialized` file written by hand: version 4, one mesh (a unit square in two
    /// triangles) with normals, single precision.
    fn square_serialized(version: u16) -> Vec<u8> {
        let mut raw = Vec::new();
        raw.extend((HAS_NORMALS | SINGLE_PRECISION).to_le_bytes());
        if version == 4 {
            raw.extend(b"square\0");
        }
        raw.extend(4u64.to_le_bytes());
        raw.extend(2u64.to_le_bytes());
        for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
            p.iter().for_each(|x| raw.extend(x.to_le_bytes()));
        }
        for _ in 0..4 {
            [0f32, 0., 1.].iter().for_each(|x| raw.extend(x.to_le_bytes()));
        }
        for i in [0u32, 1, 2, 0, 2, 3] {
            raw.extend(i.to_le_bytes());
        }
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        std::io::Write::write_all(&mut z, &raw).unwrap();
        let mut file = vec![0x1C, 0x04];
        file.extend(version.to_le_bytes());
        file.extend(z.finish().unwrap());
        if version == 4 {
            file.extend(0u64.to_le_bytes());
        } else {
            file.extend(0u32.to_le_bytes());
        }
        file.extend(1u32.to_le_bytes());
        file
    }

    #[test]
    fn serialized_meshes_read_back_in_both_versions() {
        for version in [3, 4] {
            let (mesh, face_normals) = parse_serialized(&square_serialized(version), 0).unwrap();
            assert!(!face_normals);
            assert_eq!(mesh.positions.len(), 4);
            assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
            assert_eq!(mesh.normals.unwrap()[3], DVec3::Z);
            assert_eq!(mesh.name, if version == 4 { "square" } else { "" });
        }
    }

    #[test]
    fn damaged_serialized_files_are_refused_not_panicked_on() {
        let good = square_serialized(4);
        assert!(parse_serialized(&good, 1).unwrap_err().contains("out of range"));
        let mut bad_tag = good.clone();
        bad_tag[0] = 0;
        assert!(parse_serialized(&bad_tag, 0).is_err());
        for cut in [8, good.len() / 2, good.len() - 13] {
            let mut short = good[..cut].to_vec();
            short.extend(&good[good.len() - 12..]);
            assert!(parse_serialized(&short, 0).is_err(), "cut at {cut}");
        }
        for i in 4..good.len() {
            let mut flipped = good.clone();
            flipped[i] ^= 0x5A;
            let _ = parse_serialized(&flipped, 0);
        }
    }

    #[test]
    fn ply_ascii_and_binary_give_the_same_mesh_and_fan_polygons() {
        let ascii = b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
        let mut binary =
            b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                .to_vec();
        for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
            p.iter().for_each(|x| binary.extend(x.to_le_bytes()));
        }
        binary.push(4);
        for i in [0i32, 1, 2, 3] {
            binary.extend(i.to_le_bytes());
        }
        for bytes in [&ascii[..], &binary[..]] {
            let mesh = parse_ply(bytes).unwrap();
            assert_eq!(mesh.positions[2], DVec3::new(1.0, 1.0, 0.0));
            assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
            assert!(mesh.normals.is_none());
        }
        let out_of_range = String::from_utf8_lossy(ascii).replace("4 0 1 2 3", "3 0 1 9");
        assert!(parse_ply(out_of_range.as_bytes()).unwrap_err().contains("vertex 9"));
        assert!(parse_ply(b"ply\nformat ascii 1.0\nend").is_err());
    }

    /// Mitsuba 3.9.1's names and values (probed with its PLY reader): `r g b` (8-bit values
    /// kept as they are) or `red green blue alpha` become `vertex_color`; `NAME_0 NAME_1 …`
    /// become `vertex_NAME` (and win over `r g b`); a face's values repeat for each triangle
    /// fanned from it; a property without a numbered postfix is not an attribute. (Our rule
    /// where Mitsuba's was not probed: a numbered property after a gap in the numbering is
    /// ignored.)
    #[test]
    fn ply_attributes_are_named_and_valued_as_mitsuba_reads_them() {
        let ply = |vertex_props: &str, vertex_values: &str, face_props: &str, face_values: &str| {
            let props = |names: &str, ty: &str| -> String {
                names
                    .split_whitespace()
                    .map(|n| format!("property {ty} {n}\n"))
                    .collect()
            };
            format!(
                "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n{}\
                 element face 1\nproperty list uchar int vertex_indices\n{}end_header\n\
                 0 0 0 {vertex_values}\n1 0 0 {vertex_values}\n1 1 0 {vertex_values}\n0 1 0 {vertex_values}\n\
                 4 0 1 2 3 {face_values}\n",
                props(vertex_props, "uchar"),
                props(face_props, "float"),
            )
        };
        let attrs = |text: String| parse_ply(text.as_bytes()).unwrap().attributes;
        let a = attrs(ply("r g b", "255 128 0", "", ""));
        assert_eq!(a.len(), 1);
        assert_eq!(
            (a[0].name.as_str(), a[0].channels, a[0].per_face),
            ("vertex_color", 3, false)
        );
        assert_eq!(&a[0].values[..3], &[255.0, 128.0, 0.0]);
        let a = attrs(ply("red green blue alpha", "1 2 3 4", "", ""));
        assert_eq!((a[0].name.as_str(), a[0].channels), ("vertex_color", 4));
        let a = attrs(ply(
            "r g b color_0 color_1 color_2 w_0 foo gap_0 gap_2",
            "1 2 3 4 5 6 7 8 9 10",
            "",
            "",
        ));
        let names: Vec<(&str, usize)> = a.iter().map(|a| (a.name.as_str(), a.channels)).collect();
        assert_eq!(names, [("vertex_color", 3), ("vertex_w", 1), ("vertex_gap", 1)]);
        assert_eq!(&a[0].values[..3], &[4.0, 5.0, 6.0]);
        // A quad: two triangles, each with the face's values.
        let a = attrs(ply("", "", "color_0 color_1 color_2", "0.1 0.2 0.3"));
        assert_eq!(
            (a[0].name.as_str(), a[0].channels, a[0].per_face),
            ("face_color", 3, true)
        );
        assert_eq!(a[0].values, [0.1, 0.2, 0.3, 0.1, 0.2, 0.3]);
    }

    #[test]
    fn angle_weighted_normals_are_the_plane_normal_on_a_plane_and_bisect_a_fold() {
        let flat = angle_weighted_normals(
            &[DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y],
            &[[0, 1, 2], [0, 2, 3]],
        );
        assert!(flat.iter().all(|n| (*n - DVec3::Z).length() < 1e-12));
        // Two faces at a right angle sharing the edge 0–1: the edge's normals bisect them.
        let fold = angle_weighted_normals(&[DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z], &[[0, 1, 2], [0, 3, 1]]);
        let expected = DVec3::new(0.0, 1.0, 1.0).normalize();
        assert!((fold[1] - expected).length() < 1e-12, "{}", fold[1]);
    }
}
