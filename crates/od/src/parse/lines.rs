//! The line splitter the scanner reads with: each line with the position of its first `=`,
//! found in the same pass.
/// Splits text into lines like `str::split('\n')` (a final piece after the last newline, even
/// if empty), with the position of each line's first `=`. Reads eight bytes at a time and
/// finds both bytes in each word with bit arithmetic (lines are short: one pass over a line
/// beats two `memchr` calls, and both beat a byte loop, the parser's largest single cost once).
pub(super) struct Lines<'a> {
    pub(super) text: &'a str,
    /// Start of the next line; past the end when done.
    pub(super) offset: usize,
}

/// `0x01` in every byte of a word.
pub(super) const ONES: u64 = u64::from_le_bytes([1; 8]);

/// A word whose lowest set bit is the high bit of the first byte of `w` equal to `b`, or zero
/// when no byte is (bits above the first match may be set spuriously; they are never read).
pub(super) const fn find_byte(w: u64, b: u8) -> u64 {
    let x = w ^ (ONES * b as u64);
    x.wrapping_sub(ONES) & !x & (ONES << 7)
}

impl<'a> Lines<'a> {
    // Called once per line from the scanner's loop, in another module: inlined there.
    #[inline]
    pub(super) fn next_line(&mut self) -> Option<(&'a str, Option<usize>)> {
        let rest = self.text.as_bytes().get(self.offset..)?;
        let mut eq = None;
        let mut i = 0;
        let end = loop {
            let Some(word) = rest.get(i..i + 8).and_then(|c| <[u8; 8]>::try_from(c).ok()) else {
                // Fewer than eight bytes left: byte by byte.
                let tail = rest.get(i..).unwrap_or(&[]);
                let nl = tail
                    .iter()
                    .position(|&c| c == b'\n')
                    .map_or(rest.len(), |p| i + p);
                if eq.is_none() {
                    eq = rest
                        .get(i..nl)
                        .and_then(|t| t.iter().position(|&c| c == b'='));
                    eq = eq.map(|p| i + p);
                }
                break nl;
            };
            let w = u64::from_le_bytes(word);
            let nl = find_byte(w, b'\n');
            let nl_at = (nl != 0).then(|| i + (nl.trailing_zeros() / 8) as usize);
            if eq.is_none() {
                let e = find_byte(w, b'=');
                if e != 0 {
                    let at = i + (e.trailing_zeros() / 8) as usize;
                    if nl_at.is_none_or(|n| at < n) {
                        eq = Some(at);
                    }
                }
            }
            if let Some(n) = nl_at {
                break n;
            }
            i += 8;
        };
        // `\n` and `=` are ASCII, so both positions are character boundaries.
        let line = self.text.get(self.offset..self.offset + end).unwrap_or("");
        self.offset += end + 1;
        Some((line, eq))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::string::String;
    use alloc::vec::Vec;

    #[test]
    fn lines_split_like_str_split() {
        // What `Lines` must give: `str::split('\n')` with each piece's first `=`.
        fn check(text: &str) {
            let mut lines = Lines { text, offset: 0 };
            let mut got = Vec::new();
            while let Some(l) = lines.next_line() {
                got.push(l);
            }
            let want: Vec<(&str, Option<usize>)> =
                text.split('\n').map(|l| (l, l.find('='))).collect();
            assert_eq!(got, want, "{text:?}");
        }
        for text in [
            "",
            "\n",
            "a",
            "a\n",
            "a=b\r\nc\n\n=d=e\nf",
            "k=v\n[x]\n\u{e9}=\u{fc}\n",
            "ParameterName=Producer heartbeat time\r\nDataType=0x0006\r\n[1017]\r\n",
            "0123456789abcdef=0123456789\n=\n01234567=\n0123456\n=0123456789abcdef",
        ] {
            check(text);
        }
        // Every text of up to ten bytes over `a`, `=` and a newline: the word-at-a-time search
        // must agree at every alignment.
        let mut text = String::new();
        for len in 0..=10u32 {
            for mut n in 0..3usize.pow(len) {
                text.clear();
                for _ in 0..len {
                    text.push(['a', '=', '\n'][n % 3]);
                    n /= 3;
                }
                check(&text);
            }
        }
        // Longer texts, so that lines and their `=` cross word boundaries at every offset and
        // some lines run over many words: pseudo-random (xorshift) over the same bytes, with
        // newlines and `=` signs dense or rare.
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        for round in 0..4000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let len = (seed % 300) as usize;
            let (p_nl, p_eq) = [(3, 3), (40, 5), (3, 90), (150, 150)][round % 4];
            text.clear();
            let mut r = seed;
            for _ in 0..len {
                r ^= r << 13;
                r ^= r >> 7;
                r ^= r << 17;
                let c = if r.is_multiple_of(p_nl) {
                    '\n'
                } else if (r >> 20).is_multiple_of(p_eq) {
                    '='
                } else {
                    'a'
                };
                text.push(c);
            }
            check(&text);
        }
    }
}
