//! Buffers and accessors, read with every offset and length checked, so a malformed or
//! hostile file gets an error naming the element rather than a panic or a huge allocation.

use std::path::Path;

use gltf::accessor::{DataType, Dimensions};

use super::uri::{read_uri, LoadOptions};
use crate::error::{Error, Result};

/// An accessor with no buffer view is all zeros (plus sparse values); beyond this many
/// elements such a file is rejected rather than allocated.
const MAX_VIEWLESS_ELEMENTS: usize = 1 << 28;

/// Loads every buffer: the GLB binary chunk, `data:` URIs, or files beside the glTF, under
/// the external-URI rule of [`super::uri`].
pub fn load_buffers(
    doc: &gltf::Document,
    blob: Option<&[u8]>,
    file: &Path,
    options: &LoadOptions,
) -> Result<Vec<Vec<u8>>> {
    let folder = scene_folder(file);
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let i = buffer.index();
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .ok_or_else(|| {
                    Error::scene(
                        file,
                        format!("buffer {i} refers to the GLB binary chunk, but the file has none"),
                    )
                })?
                .to_vec(),
            gltf::buffer::Source::Uri(uri) => {
                read_uri(uri, folder, options).map_err(|m| Error::scene(file, format!("buffer {i}: {m}")))?
            }
        };
        if data.len() < buffer.length() {
            return Err(Error::scene(
                file,
                format!("buffer {i} declares {} bytes but only {} are present", buffer.length(), data.len()),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// The folder a scene's relative URIs start from.
pub fn scene_folder(file: &Path) -> &Path {
    match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

fn component_size(t: DataType) -> usize {
    match t {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

/// A checked window onto a buffer: element `i` is `count` × `elem_size` bytes at
/// `base + i·stride`.
struct Strided<'a> {
    bytes: &'a [u8],
    stride: usize,
    elem_size: usize,
    count: usize,
}

impl<'a> Strided<'a> {
    /// `what` names the element for errors.
    fn new(
        buffers: &'a [Vec<u8>],
        view: &gltf::buffer::View,
        offset: usize,
        count: usize,
        elem_size: usize,
        what: &str,
    ) -> std::result::Result<Strided<'a>, String> {
        let buffer = &buffers[view.buffer().index()];
        let view_end =
            view.offset().checked_add(view.length()).filter(|end| *end <= buffer.len()).ok_or_else(|| {
                format!(
                    "{what}: buffer view {} (bytes {}..+{}) lies outside buffer {} ({} bytes)",
                    view.index(),
                    view.offset(),
                    view.length(),
                    view.buffer().index(),
                    buffer.len()
                )
            })?;
        let bytes = &buffer[view.offset()..view_end];
        let stride = view.stride().unwrap_or(elem_size);
        if stride < elem_size {
            return Err(format!("{what}: byteStride {stride} is smaller than the element size {elem_size}"));
        }
        if count > 0 {
            let needed = (count - 1)
                .checked_mul(stride)
                .and_then(|v| v.checked_add(elem_size))
                .and_then(|v| v.checked_add(offset));
            match needed {
                Some(n) if n <= bytes.len() => {}
                _ => {
                    return Err(format!(
                        "{what}: {count} elements of {elem_size} bytes (stride {stride}, offset {offset}) do not fit in buffer view {} ({} bytes)",
                        view.index(),
                        bytes.len()
                    ))
                }
            }
        }
        Ok(Strided { bytes: &bytes[offset.min(bytes.len())..], stride, elem_size, count })
    }

    fn element(&self, i: usize) -> &'a [u8] {
        let start = i * self.stride;
        &self.bytes[start..start + self.elem_size]
    }
}

fn read_f32(b: &[u8]) -> f32 {
    f32::from_le_bytes([b[0], b[1], b[2], b[3]])
}

fn read_uint(t: DataType, b: &[u8]) -> u32 {
    match t {
        DataType::U8 => b[0] as u32,
        DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as u32,
        _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
    }
}

/// Reads an accessor's raw elements (dense, then sparse substitution) as byte vectors of
/// `elem_size` each, concatenated.
fn read_raw(
    buffers: &[Vec<u8>],
    accessor: &gltf::Accessor,
    what: &str,
) -> std::result::Result<Vec<u8>, String> {
    let count = accessor.count();
    let elem_size = component_size(accessor.data_type()) * accessor.dimensions().multiplicity();
    let mut out;
    match accessor.view() {
        Some(view) => {
            let s = Strided::new(buffers, &view, accessor.offset(), count, elem_size, what)?;
            out = Vec::with_capacity(count * elem_size);
            for i in 0..s.count {
                out.extend_from_slice(s.element(i));
            }
        }
        None => {
            if count > MAX_VIEWLESS_ELEMENTS {
                return Err(format!("{what}: {count} elements with no buffer view is not a plausible count"));
            }
            out = vec![0u8; count * elem_size];
        }
    }
    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        let index_type = match sparse.indices().index_type() {
            gltf::accessor::sparse::IndexType::U8 => DataType::U8,
            gltf::accessor::sparse::IndexType::U16 => DataType::U16,
            gltf::accessor::sparse::IndexType::U32 => DataType::U32,
        };
        let idx_view = sparse.indices().view();
        let indices = Strided::new(
            buffers,
            &idx_view,
            sparse.indices().offset(),
            n,
            component_size(index_type),
            &format!("{what} sparse indices"),
        )?;
        let val_view = sparse.values().view();
        let values = Strided::new(
            buffers,
            &val_view,
            sparse.values().offset(),
            n,
            elem_size,
            &format!("{what} sparse values"),
        )?;
        // Sparse views are tightly packed by definition (no byteStride).
        for k in 0..n {
            let target = read_uint(index_type, indices.element(k)) as usize;
            if target >= count {
                // The position, not the value: buffer contents are never quoted (they may be
                // any file's bytes).
                return Err(format!("{what}: sparse index {k} is out of range (count {count})"));
            }
            out[target * elem_size..(target + 1) * elem_size].copy_from_slice(values.element(k));
        }
    }
    Ok(out)
}

/// Reads a FLOAT VEC3 accessor (POSITION, NORMAL).
pub fn read_vec3(
    buffers: &[Vec<u8>],
    accessor: &gltf::Accessor,
    what: &str,
) -> std::result::Result<Vec<[f32; 3]>, String> {
    if accessor.data_type() != DataType::F32 || accessor.dimensions() != Dimensions::Vec3 {
        return Err(format!(
            "{what} (accessor {}) is {:?} {:?}; only FLOAT VEC3 is supported (KHR_mesh_quantization is not)",
            accessor.index(),
            accessor.data_type(),
            accessor.dimensions()
        ));
    }
    let raw = read_raw(buffers, accessor, &format!("{what} (accessor {})", accessor.index()))?;
    Ok(raw.chunks_exact(12).map(|c| [read_f32(&c[0..4]), read_f32(&c[4..8]), read_f32(&c[8..12])]).collect())
}

/// Reads an index accessor (UNSIGNED_BYTE/SHORT/INT SCALAR).
pub fn read_indices(
    buffers: &[Vec<u8>],
    accessor: &gltf::Accessor,
    what: &str,
) -> std::result::Result<Vec<u32>, String> {
    let t = accessor.data_type();
    if !matches!(t, DataType::U8 | DataType::U16 | DataType::U32)
        || accessor.dimensions() != Dimensions::Scalar
    {
        return Err(format!(
            "{what} (accessor {}) is {:?} {:?}; indices must be unsigned byte, short or int scalars",
            accessor.index(),
            t,
            accessor.dimensions()
        ));
    }
    let size = component_size(t);
    let raw = read_raw(buffers, accessor, &format!("{what} (accessor {})", accessor.index()))?;
    Ok(raw.chunks_exact(size).map(|c| read_uint(t, c)).collect())
}

/// Reads a VEC2 or VEC4 accessor as f32s: FLOAT, or normalized UNSIGNED_BYTE/SHORT (as glTF
/// allows for TEXCOORD_n). `dims` is 2 or 4.
pub fn read_floats(
    buffers: &[Vec<u8>],
    accessor: &gltf::Accessor,
    what: &str,
    dims: Dimensions,
) -> std::result::Result<Vec<f32>, String> {
    let t = accessor.data_type();
    let ok_type = match t {
        DataType::F32 => true,
        DataType::U8 | DataType::U16 => accessor.normalized(),
        _ => false,
    };
    if accessor.dimensions() != dims || !ok_type {
        return Err(format!(
            "{what} (accessor {}) is {:?} {:?}{}; expected {dims:?} of FLOAT or normalized unsigned byte/short",
            accessor.index(),
            t,
            accessor.dimensions(),
            if accessor.normalized() { " normalized" } else { "" }
        ));
    }
    let raw = read_raw(buffers, accessor, &format!("{what} (accessor {})", accessor.index()))?;
    let size = component_size(t);
    let values: Vec<f32> = raw
        .chunks_exact(size)
        .map(|c| match t {
            DataType::U8 => c[0] as f32 / 255.0,
            DataType::U16 => u16::from_le_bytes([c[0], c[1]]) as f32 / 65535.0,
            _ => read_f32(c),
        })
        .collect();
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "{what} (accessor {}) element {} is not finite",
            accessor.index(),
            i / dims.multiplicity()
        ));
    }
    Ok(values)
}
