//! Line and column of a byte offset in a scene file, for error messages. The
//! loader asks once per primitive and per error, so the line starts are found
//! once and each lookup is a binary search: rescanning the text per lookup was
//! quadratic in the file (block-spheres-1024: 1,025 primitives, 7,000 lines).

/// The byte offsets where the lines of a text begin.
#[derive(Clone, Debug)]
pub(super) struct LineIndex {
    /// `starts[i]`: offset of line `i + 1`'s first byte; `starts[0] == 0`.
    starts: Vec<usize>,
    len: usize,
}

impl LineIndex {
    pub(super) fn new(text: &str) -> LineIndex {
        let starts = std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect();
        LineIndex {
            starts,
            len: text.len(),
        }
    }

    /// 1-based line and column (in characters) of byte `offset` of `text`, the
    /// text this index was made of; offsets past the end count as the end.
    pub(super) fn line_col(&self, text: &str, offset: usize) -> (usize, usize) {
        debug_assert_eq!(text.len(), self.len, "a line index of another text");
        let offset = offset.min(text.len());
        // The last line start at or before `offset`.
        let line = self.starts.partition_point(|&s| s <= offset);
        let start = self.starts[line - 1];
        let col = text.get(start..offset).map_or(0, |s| s.chars().count()) + 1;
        (line, col)
    }
}

#[cfg(test)]
mod tests {
    use super::LineIndex;

    /// The definition the index replaces: count the newlines before `offset`.
    fn rescan(text: &str, offset: usize) -> (usize, usize) {
        let before = &text[..offset.min(text.len())];
        let line = before.matches('\n').count() + 1;
        let col = before.rsplit('\n').next().unwrap_or("").chars().count() + 1;
        (line, col)
    }

    #[test]
    fn every_offset_gets_the_line_and_column_a_rescan_gives() {
        for text in [
            "",
            "a",
            "\n",
            "ab\ncd\n\nxé\n",
            "x = 1\n[csg]\nexpr = \"A - B\"",
            "\n\né",
        ] {
            let idx = LineIndex::new(text);
            for offset in (0..=text.len() + 2).filter(|&o| text.is_char_boundary(o.min(text.len())))
            {
                assert_eq!(
                    idx.line_col(text, offset),
                    rescan(text, offset),
                    "{text:?} at {offset}"
                );
            }
        }
    }

    #[test]
    fn lines_and_columns_count_from_one() {
        let text = "name = \"s\"\n\n[camera]\neye = [1, 2, 3]\n";
        let idx = LineIndex::new(text);
        assert_eq!(idx.line_col(text, 0), (1, 1));
        assert_eq!(idx.line_col(text, text.find("[camera]").unwrap()), (3, 1));
        assert_eq!(idx.line_col(text, text.find("[1").unwrap()), (4, 7));
        assert_eq!(idx.line_col(text, text.len()), (5, 1));
    }

    #[test]
    fn a_large_file_is_indexed_in_linear_time() {
        // 200,000 lines, a lookup on each: a rescan per lookup would be 10^10 steps.
        let text = "k = 1\n".repeat(200_000);
        let idx = LineIndex::new(&text);
        let mut sum = 0;
        for line in 0..200_000 {
            sum += idx.line_col(&text, line * 6 + 4).0;
        }
        assert_eq!(sum, (1..=200_000).sum::<usize>());
    }
}
