//! Bit rates as people write them: `500000`, `500k`, `1M`, `83.3k`. The one parser of bit-rate
//! text in the workspace (the CLI's options and slcan's `PATH@BITRATE` both use it).

/// The bit rate in bit/s that `text` spells: a whole number of bit/s, or a number with a `k`
/// (kbit/s) or `M` (Mbit/s) suffix, either case, with decimals where they give whole bit/s
/// (`1.5M`). `83.3k` is the usual spelling of 83 333 bit/s and reads as that. `None` for
/// anything else, for 0, and beyond `u32`.
///
/// ```
/// use canola_frame::parse_bitrate;
/// assert_eq!(parse_bitrate("500k"), Some(500_000));
/// assert_eq!(parse_bitrate("1M"), Some(1_000_000));
/// assert_eq!(parse_bitrate("83.3k"), Some(83_333));
/// assert_eq!(parse_bitrate("250000"), Some(250_000));
/// assert_eq!(parse_bitrate("fast"), None);
/// ```
pub fn parse_bitrate(text: &str) -> Option<u32> {
    let (number, scale) = match text.as_bytes().last()? {
        b'k' | b'K' => (&text[..text.len() - 1], 1_000u64),
        b'm' | b'M' => (&text[..text.len() - 1], 1_000_000u64),
        _ => (text, 1u64),
    };
    let (whole, fraction) = match number.split_once('.') {
        Some((_, "")) => return None,
        Some(parts) => parts,
        None => (number, ""),
    };
    let digits = |s: &str| !s.is_empty() && s.len() <= 10 && s.bytes().all(|b| b.is_ascii_digit());
    if !digits(whole) || !(fraction.is_empty() || digits(fraction)) {
        return None;
    }
    // Every fraction digit must stand for whole bit/s: 10^len divides the scale.
    let divisor = 10u64.checked_pow(u32::try_from(fraction.len()).ok()?)?;
    if scale % divisor != 0 {
        return None;
    }
    let whole: u64 = whole.parse().ok()?;
    let fraction: u64 = if fraction.is_empty() {
        0
    } else {
        fraction.parse().ok()?
    };
    let bps = whole.checked_mul(scale)? + fraction * (scale / divisor);
    let bps = u32::try_from(bps).ok().filter(|&b| b > 0)?;
    Some(if bps == 83_300 { 83_333 } else { bps })
}

#[cfg(test)]
mod tests {
    use super::parse_bitrate;

    #[test]
    fn spellings() {
        for (text, bps) in [
            ("10k", 10_000),
            ("20K", 20_000),
            ("125k", 125_000),
            ("500000", 500_000),
            ("800k", 800_000),
            ("1m", 1_000_000),
            ("1M", 1_000_000),
            ("1.5M", 1_500_000),
            ("2M", 2_000_000),
            ("83.3k", 83_333),
            ("83333", 83_333),
            ("0.5M", 500_000),
        ] {
            assert_eq!(parse_bitrate(text), Some(bps), "{text}");
        }
    }

    #[test]
    fn refusals() {
        for text in [
            "",
            "k",
            "M",
            "0",
            "0k",
            "-1",
            "1.k",
            ".5k",
            "1.2.3k",
            "1.0001k",
            "500.5",
            "5e5",
            "500 k",
            "4295M",
            "99999999999",
            "fast",
            "1G",
        ] {
            assert_eq!(parse_bitrate(text), None, "{text}");
        }
    }
}
