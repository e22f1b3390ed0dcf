//! A bounds-checked little-endian cursor over a file, held in memory or streamed from disk
//! through a window: every read that would run past the end is an error, so no length field
//! from the file is ever trusted, and a streamed file never needs memory for more than the
//! largest single read (a compressed leaf buffer) plus the window.

use anyhow::{bail, ensure, Context, Result};
use std::io::{Read, Seek, SeekFrom};

/// Bytes a streamed reader fetches at once (more when one read asks for more).
const WINDOW: usize = 1 << 20;

/// What a [`ByteReader`] reads from: a file, or bytes in memory (tests).
trait Source: Read + Seek {}
impl<T: Read + Seek> Source for T {}

/// Reads little-endian values from a file (or bytes in memory) through a window, failing
/// cleanly at the end of the data.
pub struct ByteReader<'a> {
    src: Box<dyn Source + 'a>,
    /// The bytes last read, from offset `start`.
    window: Vec<u8>,
    start: usize,
    len: usize,
    pos: usize,
}

impl<'a> ByteReader<'a> {
    /// A cursor at the start of `data`.
    #[cfg(test)]
    pub fn new(data: &'a [u8]) -> Self {
        ByteReader::with_source(Box::new(std::io::Cursor::new(data)), data.len() as u64)
    }

    /// A cursor at the start of the first `len` bytes of any reader (tests that count reads).
    #[cfg(test)]
    pub fn from_source(src: impl Read + Seek + 'a, len: u64) -> Self {
        ByteReader::with_source(Box::new(src), len)
    }

    /// A cursor at the start of the first `len` bytes of `file`, read through a window.
    pub fn stream(file: std::fs::File, len: u64) -> Self {
        ByteReader::with_source(Box::new(file), len)
    }

    fn with_source(src: Box<dyn Source + 'a>, len: u64) -> Self {
        ByteReader {
            src,
            window: Vec::new(),
            start: 0,
            len: usize::try_from(len).unwrap_or(usize::MAX),
            pos: 0,
        }
    }

    /// The current offset from the start of the data.
    pub fn pos(&self) -> usize {
        self.pos
    }

    /// Bytes left after the current offset.
    pub fn remaining(&self) -> usize {
        self.len - self.pos
    }

    /// Moves to absolute offset `pos`, which must lie within the data.
    pub fn seek(&mut self, pos: u64) -> Result<()> {
        ensure!(
            pos <= self.len as u64,
            "offset {pos} points past the end of the file ({} bytes): the file is truncated or corrupt",
            self.len
        );
        self.pos = pos as usize;
        Ok(())
    }

    /// The next `n` bytes.
    pub fn bytes(&mut self, n: usize) -> Result<&[u8]> {
        if n > self.remaining() {
            bail!(
                "unexpected end of file at byte {} (needed {n} more bytes, {} left): the file is truncated",
                self.pos,
                self.remaining()
            );
        }
        let at = self.pos;
        if at < self.start || at + n > self.start + self.window.len() {
            // n <= the bytes left in the file: a length field cannot make this allocate more
            // than the file holds.
            self.window.clear();
            self.window.resize(n.max(WINDOW).min(self.len - at), 0);
            let window = &mut self.window;
            self.src
                .seek(SeekFrom::Start(at as u64))
                .and_then(|_| self.src.read_exact(window))
                .with_context(|| {
                    format!(
                        "cannot read {} bytes at byte {at}: the file shrank or the disk failed \
                         while loading",
                        window.len()
                    )
                })?;
            self.start = at;
        }
        self.pos += n;
        Ok(&self.window[at - self.start..at - self.start + n])
    }

    /// The next `N` bytes as an array.
    pub fn array<const N: usize>(&mut self) -> Result<[u8; N]> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.bytes(N)?);
        Ok(out)
    }

    /// Skips `n` bytes.
    pub fn skip(&mut self, n: u64) -> Result<()> {
        let n = usize::try_from(n).unwrap_or(usize::MAX);
        self.bytes(n).map(|_| ())
    }

    /// One byte.
    pub fn u8(&mut self) -> Result<u8> {
        Ok(self.array::<1>()?[0])
    }

    /// A little-endian u32.
    pub fn u32(&mut self) -> Result<u32> {
        Ok(u32::from_le_bytes(self.array()?))
    }

    /// A little-endian i32.
    pub fn i32(&mut self) -> Result<i32> {
        Ok(i32::from_le_bytes(self.array()?))
    }

    /// A little-endian i64.
    pub fn i64(&mut self) -> Result<i64> {
        Ok(i64::from_le_bytes(self.array()?))
    }

    /// A little-endian u64.
    pub fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(self.array()?))
    }

    /// A little-endian f64.
    pub fn f64(&mut self) -> Result<f64> {
        Ok(f64::from_le_bytes(self.array()?))
    }

    /// Three little-endian i32s.
    pub fn coord(&mut self) -> Result<[i32; 3]> {
        Ok([self.i32()?, self.i32()?, self.i32()?])
    }

    /// Three little-endian f64s.
    pub fn vec3d(&mut self) -> Result<[f64; 3]> {
        Ok([self.f64()?, self.f64()?, self.f64()?])
    }

    /// A string stored as a u32 byte count and the bytes (non-UTF-8 bytes are replaced).
    pub fn string(&mut self) -> Result<String> {
        let len = self.u32()? as usize;
        Ok(String::from_utf8_lossy(self.bytes(len)?).into_owned())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_streamed_file_reads_as_the_bytes_in_memory() {
        use std::io::Write;
        let data: Vec<u8> = (0..3 * WINDOW + 17).map(|i| (i * 7 % 251) as u8).collect();
        let mut f = tempfile_in_target();
        f.write_all(&data).unwrap();
        let len = data.len() as u64;
        let mut s = ByteReader::stream(f, len);
        let mut m = ByteReader::new(&data);
        // Small reads across window boundaries, a read larger than the window, seeks back.
        for (seek, n) in [
            (None, 5),
            (Some(WINDOW - 2), 4),
            (None, WINDOW + 9),
            (Some(3), 1),
        ] {
            if let Some(p) = seek {
                s.seek(p as u64).unwrap();
                m.seek(p as u64).unwrap();
            }
            assert_eq!(s.bytes(n).unwrap(), m.bytes(n).unwrap());
            assert_eq!(s.pos(), m.pos());
        }
        s.seek(len - 2).unwrap();
        let err = s.u32().unwrap_err().to_string();
        assert!(err.contains("truncated"), "{err}");
        assert_eq!(s.pos() as u64, len - 2);
    }

    /// A scratch file, opened for reading and writing, removed when dropped by the OS.
    fn tempfile_in_target() -> std::fs::File {
        let path = std::env::temp_dir().join(format!("volume-io-bytes-{}", std::process::id()));
        let f = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(&path)
            .unwrap();
        std::fs::remove_file(&path).unwrap();
        f
    }

    #[test]
    fn reads_little_endian_and_stops_at_the_end() {
        let data = [1u8, 0, 0, 0, 2, b'a', b'b'];
        let mut r = ByteReader::new(&data);
        assert_eq!(r.u32().unwrap(), 1);
        assert_eq!(r.u8().unwrap(), 2);
        let err = r.u32().unwrap_err().to_string();
        assert!(err.contains("truncated"), "{err}");
        assert_eq!(r.pos(), 5, "a failed read must not move the cursor");
    }

    #[test]
    fn huge_string_length_is_an_error_not_an_allocation() {
        let data = [0xff, 0xff, 0xff, 0xff, b'x'];
        let err = ByteReader::new(&data).string().unwrap_err().to_string();
        assert!(err.contains("needed 4294967295 more bytes"), "{err}");
    }
}
