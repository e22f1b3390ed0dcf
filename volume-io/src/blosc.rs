//! A decoder for Blosc 1 buffers as OpenVDB writes them (LZ4 or zlib, byte shuffle), in safe
//! Rust: the output size is fixed by the caller, so a corrupt header cannot make it allocate.

use anyhow::{bail, ensure, Context, Result};
use std::io::Read;

/// Bytes of the Blosc 1 header.
const HEADER: usize = 16;
/// Header flag: bytes were shuffled by element before compression.
const DO_SHUFFLE: u8 = 0x1;
/// Header flag: the data is stored uncompressed right after the header.
const MEMCPYED: u8 = 0x2;
/// Header flag: bit shuffle (never written by OpenVDB).
const DO_BIT_SHUFFLE: u8 = 0x4;
/// Header flag: blocks are not split into one stream per byte of the element.
const DONT_SPLIT: u8 = 0x10;
/// Blosc's largest element size that is still split into streams.
const MAX_SPLITS: usize = 16;
/// Blosc's smallest element count per block that is split into streams.
const MIN_BUFFER_SIZE: usize = 128;
/// How many bytes past `expected` a decompressed buffer may hold (OpenVDB pads tiny buffers).
const MAX_PADDING: usize = 256;

/// Decompresses a Blosc buffer that must hold `expected` bytes (more only as OpenVDB's padding).
pub fn decompress(src: &[u8], expected: usize) -> Result<Vec<u8>> {
    ensure!(
        src.len() >= HEADER,
        "Blosc block of {} bytes is shorter than its header",
        src.len()
    );
    let flags = src[2];
    let typesize = usize::from(src[3]).max(1);
    let nbytes = le_u32(src, 4) as usize;
    let blocksize = le_u32(src, 8) as usize;
    let cbytes = le_u32(src, 12) as usize;
    ensure!(
        nbytes >= expected && nbytes <= expected.max(MAX_PADDING),
        "Blosc block decompresses to {nbytes} bytes where {expected} were expected"
    );
    ensure!(
        cbytes <= src.len(),
        "Blosc block claims {cbytes} bytes but holds {}",
        src.len()
    );
    let src = &src[..cbytes];
    let mut out = vec![0u8; nbytes];
    if flags & MEMCPYED != 0 {
        let body = src
            .get(HEADER..HEADER + nbytes)
            .context("Blosc block is truncated")?;
        out.copy_from_slice(body);
    } else {
        ensure!(
            flags & DO_BIT_SHUFFLE == 0,
            "Blosc bit shuffle is not supported"
        );
        ensure!(
            blocksize > 0 || nbytes == 0,
            "Blosc block has a zero block size"
        );
        let codec = Codec::from_flags(flags)?;
        for (b, block) in out.chunks_mut(blocksize.max(1)).enumerate() {
            let start = le_u32(src.get(HEADER + 4 * b..).unwrap_or(&[]), 0) as usize;
            let leftover = block.len() < blocksize;
            decode_block(src, start, block, typesize, flags, leftover, codec)
                .with_context(|| format!("corrupt Blosc block {b}"))?;
        }
    }
    out.truncate(expected);
    Ok(out)
}

/// Reads a little-endian u32 at `at`, or 0 past the end (callers then fail their checks).
fn le_u32(src: &[u8], at: usize) -> u32 {
    src.get(at..at + 4)
        .map_or(0, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// The compressor inside a Blosc buffer.
#[derive(Clone, Copy)]
enum Codec {
    Lz4,
    Zlib,
}

impl Codec {
    /// The codec from the header flags' top three bits.
    fn from_flags(flags: u8) -> Result<Self> {
        match flags >> 5 {
            1 => Ok(Codec::Lz4),
            3 => Ok(Codec::Zlib),
            0 => bail!("Blosc codec blosclz is not supported (OpenVDB writes lz4)"),
            n => bail!("Blosc codec {n} is not supported (OpenVDB writes lz4)"),
        }
    }

    /// Decompresses `src` into exactly `dst.len()` bytes.
    fn decode(self, src: &[u8], dst: &mut [u8]) -> Result<()> {
        let n = match self {
            Codec::Lz4 => lz4_flex::block::decompress_into(src, dst)
                .map_err(|e| anyhow::anyhow!("lz4: {e}"))?,
            Codec::Zlib => {
                flate2::read::ZlibDecoder::new(src)
                    .read_exact(dst)
                    .context("zlib")?;
                dst.len()
            }
        };
        ensure!(
            n == dst.len(),
            "stream decompressed to {n} bytes instead of {}",
            dst.len()
        );
        Ok(())
    }
}

/// Decodes one block (at offset `start` of `src`) into `dst`, undoing the byte shuffle.
fn decode_block(
    src: &[u8],
    mut start: usize,
    dst: &mut [u8],
    typesize: usize,
    flags: u8,
    leftover: bool,
    codec: Codec,
) -> Result<()> {
    let split = flags & DONT_SPLIT == 0
        && typesize <= MAX_SPLITS
        && dst.len() / typesize >= MIN_BUFFER_SIZE
        && !leftover;
    let nsplits = if split { typesize } else { 1 };
    let shuffle = flags & DO_SHUFFLE != 0 && typesize > 1;
    let mut tmp = vec![0u8; dst.len()];
    let neblock = dst.len() / nsplits;
    for part in tmp.chunks_mut(neblock.max(1)).take(nsplits) {
        let cbytes = le_u32(src.get(start..).unwrap_or(&[]), 0) as usize;
        let body = src
            .get(start + 4..)
            .and_then(|s| s.get(..cbytes))
            .context("stream runs past the end of the buffer")?;
        if cbytes == part.len() {
            part.copy_from_slice(body);
        } else {
            codec.decode(body, part)?;
        }
        start += 4 + cbytes;
    }
    if shuffle {
        unshuffle(&tmp, dst, typesize);
    } else {
        dst.copy_from_slice(&tmp);
    }
    Ok(())
}

/// Inverts Blosc's byte shuffle: byte `j` of element `i` was stored at `j * count + i`.
fn unshuffle(src: &[u8], dst: &mut [u8], typesize: usize) {
    let count = src.len() / typesize;
    for i in 0..count {
        for j in 0..typesize {
            dst[i * typesize + j] = src[j * count + i];
        }
    }
    let tail = count * typesize;
    dst[tail..].copy_from_slice(&src[tail..]);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memcpyed_buffer_round_trips() {
        let mut buf = vec![2u8, 1, MEMCPYED, 4];
        for v in [8u32, 0, 24] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        buf.extend_from_slice(&[1, 2, 3, 4, 5, 6, 7, 8]);
        assert_eq!(decompress(&buf, 8).unwrap(), vec![1, 2, 3, 4, 5, 6, 7, 8]);
    }

    #[test]
    fn oversized_claims_are_rejected_before_allocating() {
        let mut buf = vec![2u8, 1, 0x21, 4];
        for v in [u32::MAX, 256, 16] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        let err = decompress(&buf, 2048).unwrap_err().to_string();
        assert!(err.contains("4294967295 bytes where 2048"), "{err}");
    }

    #[test]
    fn garbage_streams_are_errors() {
        let mut buf = vec![2u8, 1, 0x21, 4];
        for v in [512u32, 512, 40] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        buf.extend_from_slice(&[20, 0, 0, 0, 100, 0, 0, 0]);
        buf.extend_from_slice(&[0xff; 16]);
        assert!(decompress(&buf, 512).is_err());
    }

    #[test]
    fn unshuffle_inverts_the_byte_transpose() {
        let src = [1u8, 3, 5, 2, 4, 6, 9];
        let mut dst = [0u8; 7];
        unshuffle(&src, &mut dst, 2);
        assert_eq!(dst, [1, 2, 3, 4, 5, 6, 9]);
    }
}
