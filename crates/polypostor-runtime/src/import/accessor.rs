//! Bounds-checked reading of glTF accessors.
//!
//! Every offset, stride and count is checked against the bytes actually present before
//! anything is allocated, so a forged count cannot make us allocate or read out of bounds.

use gltf::json;
use json::accessor::{ComponentType, Type};

use super::ImportError;

/// Most elements an accessor without a bufferView may declare (they are all zero).
pub const MAX_ZERO_ELEMENTS: u64 = 1 << 22;

/// Flattened accessor values: `count * components` numbers.
pub struct Values<T> {
    pub data: Vec<T>,
    pub components: usize,
}

impl<T: Copy> Values<T> {
    pub fn count(&self) -> usize {
        if self.components == 0 {
            0
        } else {
            self.data.len() / self.components
        }
    }
    pub fn get<const N: usize>(&self, i: usize) -> [T; N]
    where
        T: Default,
    {
        let mut out = [T::default(); N];
        let base = i * self.components;
        for (k, o) in out.iter_mut().enumerate().take(self.components.min(N)) {
            *o = self.data[base + k];
        }
        out
    }
}

fn component_size(c: ComponentType) -> usize {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

fn type_components(t: Type) -> usize {
    match t {
        Type::Scalar => 1,
        Type::Vec2 => 2,
        Type::Vec3 => 3,
        Type::Vec4 => 4,
        Type::Mat2 => 4,
        Type::Mat3 => 9,
        Type::Mat4 => 16,
    }
}

fn read_component(bytes: &[u8], c: ComponentType, normalized: bool) -> f64 {
    match c {
        ComponentType::I8 => {
            let v = bytes[0] as i8 as f64;
            if normalized { (v / 127.0).max(-1.0) } else { v }
        }
        ComponentType::U8 => {
            let v = bytes[0] as f64;
            if normalized { v / 255.0 } else { v }
        }
        ComponentType::I16 => {
            let v = i16::from_le_bytes([bytes[0], bytes[1]]) as f64;
            if normalized { (v / 32767.0).max(-1.0) } else { v }
        }
        ComponentType::U16 => {
            let v = u16::from_le_bytes([bytes[0], bytes[1]]) as f64;
            if normalized { v / 65535.0 } else { v }
        }
        ComponentType::U32 => u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
        ComponentType::F32 => f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
    }
}

/// The bytes of a buffer view, checked against its buffer.
pub fn view_bytes<'a>(
    root: &json::Root,
    buffers: &'a [Result<Vec<u8>, ImportError>],
    view_index: usize,
) -> Result<&'a [u8], ImportError> {
    let view = root
        .buffer_views
        .get(view_index)
        .ok_or_else(|| ImportError::Invalid(format!("bufferView {view_index} does not exist")))?;
    let buffer = match buffers.get(view.buffer.value()) {
        Some(Ok(b)) => b,
        Some(Err(e)) => return Err(ImportError::Invalid(format!("{e} (needed by bufferView {view_index})"))),
        None => {
            return Err(ImportError::Invalid(format!(
                "bufferView {view_index} refers to missing buffer {}",
                view.buffer.value()
            )));
        }
    };
    let start = view.byte_offset.map_or(0, |o| o.0);
    let end = start.checked_add(view.byte_length.0);
    match end {
        Some(end) if end <= buffer.len() as u64 => Ok(&buffer[start as usize..end as usize]),
        _ => Err(ImportError::Invalid(format!(
            "bufferView {view_index} (offset {start}, length {}) exceeds buffer {} of {} bytes",
            view.byte_length.0,
            view.buffer.value(),
            buffer.len()
        ))),
    }
}

/// Reads the strided elements of one accessor-like range, calling `f(element_index, bytes)`.
fn for_each_element(
    what: &str,
    view: &[u8],
    offset: u64,
    stride: u64,
    elem_size: u64,
    count: u64,
    mut f: impl FnMut(usize, &[u8]),
) -> Result<(), ImportError> {
    if count == 0 {
        return Ok(());
    }
    let last_end = (count - 1)
        .checked_mul(stride)
        .and_then(|x| x.checked_add(offset))
        .and_then(|x| x.checked_add(elem_size));
    match last_end {
        Some(e) if e <= view.len() as u64 => {}
        _ => {
            return Err(ImportError::Invalid(format!(
                "{what}: {count} elements of {elem_size} bytes (stride {stride}, offset {offset}) do not fit in {} bytes",
                view.len()
            )));
        }
    }
    for i in 0..count as usize {
        let at = offset as usize + i * stride as usize;
        f(i, &view[at..at + elem_size as usize]);
    }
    Ok(())
}

/// Reads an accessor as `f64` numbers (normalised integers mapped to `[0,1]` / `[-1,1]`),
/// applying sparse substitution.
pub fn read_f64(
    root: &json::Root,
    buffers: &[Result<Vec<u8>, ImportError>],
    index: usize,
) -> Result<Values<f64>, ImportError> {
    let what = format!("accessor {index}");
    let acc = root
        .accessors
        .get(index)
        .ok_or_else(|| ImportError::Invalid(format!("{what} does not exist")))?;
    let ctype = match acc.component_type {
        json::validation::Checked::Valid(c) => c.0,
        _ => {
            return Err(ImportError::Invalid(format!("{what} has an invalid componentType")));
        }
    };
    let ty = match acc.type_ {
        json::validation::Checked::Valid(t) => t,
        _ => return Err(ImportError::Invalid(format!("{what} has an invalid type"))),
    };
    let comps = type_components(ty);
    let csize = component_size(ctype);
    if matches!(ty, Type::Mat2 | Type::Mat3) && csize < 4 {
        return Err(ImportError::Unsupported(format!(
            "{what}: padded {ty:?} matrices of {csize}-byte components"
        )));
    }
    let elem_size = (comps * csize) as u64;
    let count = acc.count.0;

    let mut data: Vec<f64>;
    match acc.buffer_view {
        Some(v) => {
            let view_index = v.value();
            let view = view_bytes(root, buffers, view_index)?;
            let stride = root.buffer_views[view_index]
                .byte_stride
                .map_or(elem_size, |s| s.0 as u64);
            if stride < elem_size {
                return Err(ImportError::Invalid(format!(
                    "{what}: byteStride {stride} is smaller than the element size {elem_size}"
                )));
            }
            let offset = acc.byte_offset.map_or(0, |o| o.0);
            // for_each_element checks that the elements fit in the view before reading any.
            let mut out = Vec::new();
            for_each_element(&what, view, offset, stride, elem_size, count, |_, b| {
                for k in 0..comps {
                    out.push(read_component(&b[k * csize..], ctype, acc.normalized));
                }
            })?;
            data = out;
        }
        None => {
            if acc.byte_offset.is_some_and(|o| o.0 != 0) {
                return Err(ImportError::Invalid(format!(
                    "{what} has a byteOffset but no bufferView"
                )));
            }
            // No bufferView: all zeros (then sparse substitution). Nothing in the file backs
            // the count, so it is bounded to keep a forged one from allocating without limit.
            if count > MAX_ZERO_ELEMENTS {
                return Err(ImportError::Invalid(format!(
                    "{what}: {count} elements without a bufferView (at most {MAX_ZERO_ELEMENTS})"
                )));
            }
            data = vec![0.0; (count as usize) * comps];
        }
    }

    if let Some(sparse) = &acc.sparse {
        let n = sparse.count.0;
        if n > count {
            return Err(ImportError::Invalid(format!(
                "{what}: sparse count {n} exceeds the accessor count {count}"
            )));
        }
        let ictype = match sparse.indices.component_type {
            json::validation::Checked::Valid(c) => c.0,
            _ => {
                return Err(ImportError::Invalid(format!(
                    "{what}: sparse indices have an invalid componentType"
                )));
            }
        };
        let isize = component_size(ictype) as u64;
        let iview = view_bytes(root, buffers, sparse.indices.buffer_view.value())?;
        let mut indices = Vec::new();
        for_each_element(
            &format!("{what} sparse indices"),
            iview,
            sparse.indices.byte_offset.0,
            isize,
            isize,
            n,
            |_, b| {
                indices.push(read_component(b, ictype, false) as u64);
            },
        )?;
        let vview = view_bytes(root, buffers, sparse.values.buffer_view.value())?;
        let mut values = Vec::new();
        for_each_element(
            &format!("{what} sparse values"),
            vview,
            sparse.values.byte_offset.0,
            elem_size,
            elem_size,
            n,
            |_, b| {
                for k in 0..comps {
                    values.push(read_component(&b[k * csize..], ctype, acc.normalized));
                }
            },
        )?;
        for (s, &target) in indices.iter().enumerate() {
            if target >= count {
                return Err(ImportError::Invalid(format!(
                    "{what}: sparse index {target} is out of range (count {count})"
                )));
            }
            let t = target as usize * comps;
            data[t..t + comps].copy_from_slice(&values[s * comps..(s + 1) * comps]);
        }
    }
    Ok(Values {
        data,
        components: comps,
    })
}

/// Reads an accessor as `f32`.
pub fn read_f32(
    root: &json::Root,
    buffers: &[Result<Vec<u8>, ImportError>],
    index: usize,
) -> Result<Values<f32>, ImportError> {
    let v = read_f64(root, buffers, index)?;
    Ok(Values {
        data: v.data.into_iter().map(|x| x as f32).collect(),
        components: v.components,
    })
}

/// Reads an integer accessor (indices, joints) as `u32`; non-integer data is an error.
pub fn read_u32(
    root: &json::Root,
    buffers: &[Result<Vec<u8>, ImportError>],
    index: usize,
) -> Result<Values<u32>, ImportError> {
    let is_float = root
        .accessors
        .get(index)
        .is_some_and(|a| matches!(a.component_type, json::validation::Checked::Valid(c) if c.0 == ComponentType::F32));
    if is_float {
        return Err(ImportError::Invalid(format!(
            "accessor {index} must hold integers, not floats"
        )));
    }
    let v = read_f64(root, buffers, index)?;
    Ok(Values {
        data: v.data.into_iter().map(|x| x as u32).collect(),
        components: v.components,
    })
}
