//! LZF compression and decompression, for PCD's `binary_compressed` data (PCL compresses
//! with liblzf).
//!
//! An LZF stream is a run of chunks, each opened by a control byte `c`:
//! - `c < 32`: a literal run, the next `c + 1` bytes copied as they are;
//! - otherwise a back reference: length `(c >> 5) + 2`, where a top field of 7 takes the
//!   next byte added to it; distance `((c & 31) << 8) + next byte + 1` back from the end of
//!   what is decompressed so far. The copy may overlap what it writes (a run).

/// The most bytes a compressed byte can stand for: a back reference of 3 bytes copies at
/// most 7 + 255 + 2 = 264 bytes.
pub(crate) const MAX_EXPANSION: u64 = 88;

/// `input` decompressed to exactly `expected` bytes; what is wrong with the stream, in
/// words, otherwise.
pub(crate) fn decompress(input: &[u8], expected: usize) -> Result<Vec<u8>, String> {
    let mut out: Vec<u8> = Vec::with_capacity(expected);
    let mut at = 0;
    let byte = |at: usize| {
        input
            .get(at)
            .copied()
            .ok_or_else(|| format!("the compressed data ends inside a chunk at byte {at}"))
    };
    while at < input.len() {
        let control = usize::from(input[at]);
        at += 1;
        if control < 32 {
            let run = control + 1;
            let literal = input.get(at..at + run).ok_or_else(|| {
                format!("a literal run of {run} bytes at byte {at} passes the data's end")
            })?;
            if out.len() + run > expected {
                return Err(too_long(expected));
            }
            out.extend_from_slice(literal);
            at += run;
        } else {
            let mut length = control >> 5;
            if length == 7 {
                length += usize::from(byte(at)?);
                at += 1;
            }
            length += 2;
            let distance = ((control & 31) << 8) + usize::from(byte(at)?) + 1;
            at += 1;
            if distance > out.len() {
                return Err(format!(
                    "a back reference at byte {} reaches {distance} bytes back, before the \
                     start",
                    at - 2
                ));
            }
            if out.len() + length > expected {
                return Err(too_long(expected));
            }
            let from = out.len() - distance;
            for k in from..from + length {
                out.push(out[k]);
            }
        }
    }
    if out.len() == expected {
        Ok(out)
    } else {
        Err(format!(
            "the data decompresses to {} bytes, not the {expected} the file declares",
            out.len()
        ))
    }
}

/// The farthest a back reference reaches: 13 bits of distance, minus one.
const MAX_DISTANCE: usize = 1 << 13;

/// The longest back reference: 7 + 255 + 2 bytes.
const MAX_REFERENCE: usize = 264;

/// The longest literal run.
const MAX_LITERAL: usize = 32;

/// `input` compressed: greedy matching of the last position each 3-byte prefix (hashed)
/// was seen at, within [`MAX_DISTANCE`]. Any valid LZF stream decompresses the same way;
/// this one need not match liblzf's byte for byte.
pub(crate) fn compress(input: &[u8]) -> Vec<u8> {
    const HASH_BITS: u32 = 14;
    let hash = |at: usize| {
        let word =
            u32::from(input[at]) << 16 | u32::from(input[at + 1]) << 8 | u32::from(input[at + 2]);
        (word.wrapping_mul(2_654_435_761) >> (32 - HASH_BITS)) as usize
    };
    let mut last_seen = vec![usize::MAX; 1 << HASH_BITS];
    let mut out = Vec::with_capacity(input.len() / 2 + 16);
    let mut literal_from = 0;
    let mut at = 0;
    while at + 2 < input.len() {
        let slot = &mut last_seen[hash(at)];
        let candidate = std::mem::replace(slot, at);
        let reaches = candidate != usize::MAX && at - candidate <= MAX_DISTANCE;
        if !(reaches && input[candidate..candidate + 3] == input[at..at + 3]) {
            at += 1;
            continue;
        }
        let longest = MAX_REFERENCE.min(input.len() - at);
        let mut length = 3;
        while length < longest && input[candidate + length] == input[at + length] {
            length += 1;
        }
        put_literals(&mut out, &input[literal_from..at]);
        let (offset, extra) = (at - candidate - 1, length - 2);
        let high = (offset >> 8) as u8;
        if extra < 7 {
            out.push((extra as u8) << 5 | high);
        } else {
            out.push(7 << 5 | high);
            out.push((extra - 7) as u8);
        }
        out.push((offset & 0xFF) as u8);
        at += length;
        literal_from = at;
    }
    put_literals(&mut out, &input[literal_from..]);
    out
}

/// `bytes` as literal runs of at most [`MAX_LITERAL`] bytes.
fn put_literals(out: &mut Vec<u8>, bytes: &[u8]) {
    for run in bytes.chunks(MAX_LITERAL) {
        out.push((run.len() - 1) as u8);
        out.extend_from_slice(run);
    }
}

/// The error of a stream that decompresses past the declared size.
fn too_long(expected: usize) -> String {
    format!("the data decompresses to more than the {expected} bytes the file declares")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_and_overlapping_back_references_decompress() {
        // "abc", then 7 bytes from 3 back (a run over itself), then 10 from 1 back (long
        // form: 7 + 1 + 2), then the literal "Z".
        let stream = [2, b'a', b'b', b'c', (5 << 5), 2, (7 << 5), 1, 0, 0, b'Z'];
        let mut expected = b"abcabcabca".to_vec();
        expected.extend([b'a'; 10]);
        expected.push(b'Z');
        assert_eq!(decompress(&stream, 21), Ok(expected));
    }

    #[test]
    fn compressed_bytes_decompress_to_themselves() {
        let mut state = 7u64;
        let mut noise = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            (state >> 56) as u8
        };
        // (input, whether it must come out smaller)
        let inputs: Vec<(Vec<u8>, bool)> = vec![
            (Vec::new(), false),
            (vec![9], false),
            (vec![1, 2], false),
            (vec![0; 100_000], true),
            ((0..50_000).map(|_| noise()).collect(), false),
            (
                (0..20_000u32)
                    .flat_map(|i| ((i / 100) as f32).to_le_bytes())
                    .collect(),
                true,
            ),
            (b"abcabcabcabc".repeat(700), true),
        ];
        for (input, shrinks) in inputs {
            let packed = compress(&input);
            assert_eq!(decompress(&packed, input.len()), Ok(input.clone()));
            // Incompressible bytes grow by a control byte in 32 at most.
            assert!(packed.len() <= input.len() + input.len().div_ceil(32));
            if shrinks {
                assert!(
                    packed.len() < input.len() / 2,
                    "{} of {}",
                    packed.len(),
                    input.len()
                );
            }
        }
    }

    #[test]
    fn damaged_streams_are_refused() {
        // A literal run longer than the data, a reference before the start, a chunk cut
        // after its control byte, and sizes that do not match the declared one.
        assert!(decompress(&[5, 1, 2], 6).is_err());
        assert!(decompress(&[0, 1, (1 << 5), 4], 4).is_err());
        assert!(decompress(&[0, 1, (7 << 5)], 12).is_err());
        assert!(decompress(&[1, 1, 2], 3).is_err());
        assert!(decompress(&[1, 1, 2], 1).is_err());
        assert_eq!(decompress(&[], 0), Ok(Vec::new()));
    }
}
