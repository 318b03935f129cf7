//! LZF (liblzf), the compression of PCD's `DATA binary_compressed`: a byte stream of
//! literal runs and back-references into the output already written.
//!
//! Each token starts with a control byte `c`: `c < 32` copies the next `c + 1` bytes;
//! otherwise `len = c >> 5` (7: plus the next byte) and the distance's high 5 bits are
//! `c & 31`, its low 8 bits the next byte; `len + 2` bytes are copied from
//! `distance + 1` bytes back, overlapping copies repeating the run.
//!
//! A back-reference of at most 3 bytes gives at most 264 bytes, so a stream expands
//! at most [`MAX_RATIO`] times: a reader checks a declared size against it before it
//! reserves anything. Cost: O(output) time for both directions; the compressor
//! holds a 16 K-entry table (128 KB).

use std::fmt;

/// The most bytes one input byte can decompress to.
pub const MAX_RATIO: usize = 88;

/// Why a stream does not decompress: `at` is the offset in the compressed input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LzfError {
    /// Offset of the token at fault in the compressed input.
    pub at: usize,
    /// What is wrong with it.
    pub what: &'static str,
}

impl fmt::Display for LzfError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} (compressed byte {})", self.what, self.at)
    }
}

/// Decompresses `input` into exactly `size` bytes. A stream that would write more,
/// ends short, ends inside a token or refers before the start is an error; nothing
/// beyond `size` bytes is ever reserved.
pub fn decompress(input: &[u8], size: usize) -> Result<Vec<u8>, LzfError> {
    let mut out: Vec<u8> = Vec::with_capacity(size);
    let mut ip = 0;
    while ip < input.len() {
        let at = ip;
        let err = |what| LzfError { at, what };
        let ctrl = input[ip] as usize;
        ip += 1;
        if ctrl < 32 {
            let run = input
                .get(ip..ip + ctrl + 1)
                .ok_or(err("the stream ends inside a literal run"))?;
            if out.len() + run.len() > size {
                return Err(err(
                    "the stream decompresses to more than the declared size",
                ));
            }
            out.extend_from_slice(run);
            ip += run.len();
        } else {
            let mut len = ctrl >> 5;
            if len == 7 {
                len += *input
                    .get(ip)
                    .ok_or(err("the stream ends inside a back-reference"))?
                    as usize;
                ip += 1;
            }
            let low = *input
                .get(ip)
                .ok_or(err("the stream ends inside a back-reference"))?
                as usize;
            ip += 1;
            let back = ((ctrl & 0x1f) << 8 | low) + 1;
            let len = len + 2;
            let from = out
                .len()
                .checked_sub(back)
                .ok_or(err("a back-reference points before the start of the data"))?;
            if out.len() + len > size {
                return Err(err(
                    "the stream decompresses to more than the declared size",
                ));
            }
            for k in from..from + len {
                let b = out[k];
                out.push(b);
            }
        }
    }
    if out.len() != size {
        return Err(LzfError {
            at: input.len(),
            what: "the stream decompresses to less than the declared size",
        });
    }
    Ok(out)
}

/// Compresses `input` (greedy matching through a hash table of 3-byte prefixes, as
/// liblzf does); [`decompress`] gives `input` back. The PCD tests write their
/// `binary_compressed` files with it.
pub fn compress(input: &[u8]) -> Vec<u8> {
    const HASH_BITS: u32 = 14;
    const MAX_LIT: usize = 32;
    const MAX_OFF: usize = 1 << 13;
    const MAX_REF: usize = 264;
    let mut table = vec![usize::MAX; 1 << HASH_BITS];
    let mut out = Vec::with_capacity(input.len() + input.len() / 32 + 2);
    let mut lit_start = 0;
    let flush = |out: &mut Vec<u8>, lits: &[u8]| {
        for chunk in lits.chunks(MAX_LIT) {
            out.push((chunk.len() - 1) as u8);
            out.extend_from_slice(chunk);
        }
    };
    let mut i = 0;
    while i + 2 < input.len() {
        let key =
            u32::from(input[i]) << 16 | u32::from(input[i + 1]) << 8 | u32::from(input[i + 2]);
        let h = (key.wrapping_mul(2_654_435_761) >> (32 - HASH_BITS)) as usize;
        let cand = table[h];
        table[h] = i;
        let usable =
            cand != usize::MAX && i - cand <= MAX_OFF && input[cand..cand + 3] == input[i..i + 3];
        if !usable {
            i += 1;
            continue;
        }
        let mut len = 3;
        while len < MAX_REF && i + len < input.len() && input[cand + len] == input[i + len] {
            len += 1;
        }
        flush(&mut out, &input[lit_start..i]);
        let off = i - cand - 1;
        let l = len - 2;
        if l < 7 {
            out.push((l << 5 | off >> 8) as u8);
        } else {
            out.push((7 << 5 | off >> 8) as u8);
            out.push((l - 7) as u8);
        }
        out.push(off as u8);
        i += len;
        lit_start = i;
    }
    flush(&mut out, &input[lit_start..]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_runs_repeats_and_noise() {
        let mut data = Vec::new();
        data.extend(std::iter::repeat_n(7u8, 1000));
        data.extend((0..5000u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8));
        data.extend(b"abcabcabcabcabcabd".iter().cycle().take(700));
        for input in [&data[..], b"", b"a", b"ab", b"abc"] {
            let c = compress(input);
            assert_eq!(decompress(&c, input.len()).unwrap(), input);
        }
        let c = compress(&data);
        assert!(
            c.len() < data.len() * 3 / 4,
            "{} of {}",
            c.len(),
            data.len()
        );
    }

    #[test]
    fn a_known_liblzf_stream_decompresses() {
        // "aaaaaaaaaa": literal 'a', then a back-reference of 9 at distance 1.
        assert_eq!(
            decompress(&[0, b'a', 7 << 5, 0, 0], 10).unwrap(),
            b"a".repeat(10)
        );
    }

    #[test]
    fn broken_streams_are_errors_at_their_token() {
        let e = decompress(&[0, b'a', 1 << 5, 5], 3).unwrap_err();
        assert_eq!(e.at, 2);
        assert!(e.what.contains("before the start"));
        assert!(decompress(&[4, b'a', b'b'], 5)
            .unwrap_err()
            .what
            .contains("literal"));
        assert!(decompress(&[0, b'a', 7 << 5], 20)
            .unwrap_err()
            .what
            .contains("inside"));
        assert!(decompress(&[1, b'a', b'b'], 1)
            .unwrap_err()
            .what
            .contains("more"));
        assert!(decompress(&[0, b'a'], 2).unwrap_err().what.contains("less"));
    }

    #[test]
    fn expansion_never_exceeds_the_ratio() {
        let data = vec![0u8; 100_000];
        let c = compress(&data);
        assert!(data.len() <= c.len() * MAX_RATIO);
    }
}
