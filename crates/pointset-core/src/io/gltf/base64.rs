//! Base64 (RFC 4648, standard alphabet, `=` padding): the encoding of a glTF buffer held
//! in a `data:` URI.

/// The standard alphabet.
const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// `bytes` in base64, padded with `=` to a multiple of four characters.
pub(super) fn encode(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let word = chunk
            .iter()
            .enumerate()
            .fold(0u32, |w, (k, &b)| w | u32::from(b) << (16 - 8 * k));
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(char::from(ALPHABET[(word >> (18 - 6 * k)) as usize & 63]));
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// The value of a base64 character.
fn value_of(c: u8) -> Option<u32> {
    match c {
        b'A'..=b'Z' => Some(u32::from(c - b'A')),
        b'a'..=b'z' => Some(u32::from(c - b'a') + 26),
        b'0'..=b'9' => Some(u32::from(c - b'0') + 52),
        b'+' => Some(62),
        b'/' => Some(63),
        _ => None,
    }
}

/// The bytes `text` encodes; padding is optional. Otherwise the offset of the first
/// character that is not base64 (or that leaves a dangling single character).
pub(super) fn decode(text: &str) -> Result<Vec<u8>, usize> {
    let bytes = text.as_bytes();
    let data_len = bytes.len()
        - bytes
            .iter()
            .rev()
            .take(2)
            .take_while(|&&b| b == b'=')
            .count();
    if data_len % 4 == 1 {
        return Err(data_len - 1);
    }
    let mut out = Vec::with_capacity(data_len / 4 * 3 + 2);
    for (index, chunk) in bytes[..data_len].chunks(4).enumerate() {
        let mut word = 0u32;
        for (k, &c) in chunk.iter().enumerate() {
            let v = value_of(c).ok_or(index * 4 + k)?;
            word |= v << (18 - 6 * k);
        }
        let whole = chunk.len() - 1;
        out.extend_from_slice(&word.to_be_bytes()[1..=whole]);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::{decode, encode};

    #[test]
    fn rfc_4648_test_vectors() {
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (plain, coded) in cases {
            assert_eq!(encode(plain.as_bytes()), coded);
            assert_eq!(decode(coded).as_deref(), Ok(plain.as_bytes()));
            assert_eq!(
                decode(coded.trim_end_matches('=')).as_deref(),
                Ok(plain.as_bytes())
            );
        }
    }

    #[test]
    fn every_byte_round_trips() {
        let bytes: Vec<u8> = (0..=255).chain((0..=255).rev()).collect();
        for len in [0, 1, 2, 3, 4, 5, 255, 511, 512] {
            assert_eq!(decode(&encode(&bytes[..len])), Ok(bytes[..len].to_vec()));
        }
    }

    #[test]
    fn bad_characters_are_located() {
        assert_eq!(decode("Zm9v!mFy"), Err(4));
        assert_eq!(decode("Zm 9"), Err(2));
        assert_eq!(decode("Zm9vY"), Err(4));
        assert_eq!(decode("Zg=a"), Err(2));
    }
}
