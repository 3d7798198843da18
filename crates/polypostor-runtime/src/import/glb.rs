//! The GLB container (glTF binary): a 12-byte header, a JSON chunk, at most one BIN chunk.

use super::ImportError;

const MAGIC: u32 = 0x4654_6C67; // "glTF"
const CHUNK_JSON: u32 = 0x4E4F_534A; // "JSON"
const CHUNK_BIN: u32 = 0x004E_4942; // "BIN\0"

/// The chunks of a GLB file.
#[derive(Debug)]
pub struct Glb<'a> {
    pub json: &'a [u8],
    pub bin: Option<&'a [u8]>,
}

/// True when the bytes start like a GLB file.
pub fn looks_like_glb(bytes: &[u8]) -> bool {
    bytes.len() >= 4 && u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) == MAGIC
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Splits a GLB file into its chunks, checking every length against the data.
pub fn parse<'a>(bytes: &'a [u8], warnings: &mut Vec<String>) -> Result<Glb<'a>, ImportError> {
    let err = |m: String| ImportError::Glb(m);
    if bytes.len() < 12 {
        return Err(err(format!(
            "file ends inside the 12-byte header ({} bytes)",
            bytes.len()
        )));
    }
    let magic = u32_at(bytes, 0).unwrap_or(0);
    if magic != MAGIC {
        return Err(err(format!("invalid magic 0x{magic:08X} (expected \"glTF\")")));
    }
    let version = u32_at(bytes, 4).unwrap_or(0);
    if version != 2 {
        return Err(err(format!(
            "unsupported GLB version {version} (only version 2 is supported)"
        )));
    }
    let declared = u32_at(bytes, 8).unwrap_or(0) as usize;
    if declared < 12 {
        return Err(err(format!(
            "declared total length {declared} is smaller than the header"
        )));
    }
    if declared > bytes.len() {
        return Err(err(format!(
            "declared total length {declared} exceeds the file size {}",
            bytes.len()
        )));
    }
    if declared < bytes.len() {
        warnings.push(format!(
            "GLB: {} bytes of extra data after the declared length were ignored",
            bytes.len() - declared
        ));
    }
    let data = &bytes[..declared];

    let mut at = 12usize;
    let mut json: Option<&[u8]> = None;
    let mut bin: Option<&[u8]> = None;
    let mut index = 0usize;
    while at < data.len() {
        if data.len() - at < 8 {
            return Err(err(format!(
                "chunk {index} header is truncated at byte {at} (total length declared: {declared})"
            )));
        }
        let length = u32_at(data, at).unwrap_or(0) as usize;
        let kind = u32_at(data, at + 4).unwrap_or(0);
        let start = at + 8;
        let end = start.checked_add(length).filter(|&e| e <= data.len()).ok_or_else(|| {
            err(format!(
                "chunk {index} of {length} bytes runs past the declared end ({declared} bytes)"
            ))
        })?;
        if length % 4 != 0 {
            return Err(err(format!("chunk {index} length {length} is not a multiple of 4")));
        }
        let chunk = &data[start..end];
        match (index, kind) {
            (0, CHUNK_JSON) => {
                if length == 0 {
                    return Err(err("the JSON chunk is empty".into()));
                }
                json = Some(chunk);
            }
            (0, other) => {
                return Err(err(format!(
                    "the first chunk must be JSON, found chunk type 0x{other:08X}"
                )));
            }
            (_, CHUNK_JSON) => return Err(err("more than one JSON chunk".into())),
            (1, CHUNK_BIN) => bin = Some(chunk),
            (_, CHUNK_BIN) => {
                return Err(err(if bin.is_some() {
                    "more than one BIN chunk".into()
                } else {
                    "the BIN chunk must directly follow the JSON chunk".into()
                }));
            }
            (_, other) => warnings.push(format!("GLB: unknown chunk type 0x{other:08X} ignored")),
        }
        at = end;
        index += 1;
    }
    let json = json.ok_or_else(|| err("no JSON chunk".into()))?;
    Ok(Glb { json, bin })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn glb(chunks: &[(u32, &[u8])]) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend_from_slice(&MAGIC.to_le_bytes());
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&0u32.to_le_bytes());
        for (kind, data) in chunks {
            out.extend_from_slice(&(data.len() as u32).to_le_bytes());
            out.extend_from_slice(&kind.to_le_bytes());
            out.extend_from_slice(data);
        }
        let n = out.len() as u32;
        out[8..12].copy_from_slice(&n.to_le_bytes());
        out
    }

    #[test]
    fn splits_json_and_bin() {
        let bytes = glb(&[(CHUNK_JSON, b"{}  "), (CHUNK_BIN, &[1, 2, 3, 4])]);
        let mut w = vec![];
        let g = parse(&bytes, &mut w).unwrap();
        assert_eq!(g.json, b"{}  ");
        assert_eq!(g.bin, Some(&[1u8, 2, 3, 4][..]));
        assert!(w.is_empty());
    }

    #[test]
    fn rejects_truncation_at_every_length() {
        let bytes = glb(&[(CHUNK_JSON, b"{}  "), (CHUNK_BIN, &[1, 2, 3, 4])]);
        for n in 0..bytes.len() {
            let mut cut = bytes[..n].to_vec();
            if n >= 12 {
                // Keep the declared length consistent so the chunk checks are what fail.
                let len = n as u32;
                cut[8..12].copy_from_slice(&len.to_le_bytes());
            }
            let mut w = vec![];
            let r = parse(&cut, &mut w);
            // Cutting exactly after the JSON chunk leaves a valid file.
            if n == 12 + 8 + 4 {
                assert!(r.is_ok());
            } else {
                assert!(r.is_err(), "length {n} should fail");
            }
        }
    }
}
