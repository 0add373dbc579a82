//! The edit distance behind every "did you mean" hint: the project file's names, the web
//! page's tags and the logic compilers' tags, functions and blocks. One function, so a typo is
//! measured the same way wherever it is made; each caller keeps its own rule for which
//! candidates are close enough.

/// Levenshtein distance over chars (insertions, deletions and substitutions each cost 1).
pub(crate) fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0; b.len() + 1];
    for (i, ca) in a.chars().enumerate() {
        if let Some(first) = cur.first_mut() {
            *first = i + 1;
        }
        for (j, &cb) in b.iter().enumerate() {
            let subst = prev.get(j).copied().unwrap_or(0) + usize::from(ca != cb);
            let del = prev.get(j + 1).copied().unwrap_or(0) + 1;
            let ins = cur.get(j).copied().unwrap_or(0) + 1;
            if let Some(c) = cur.get_mut(j + 1) {
                *c = subst.min(del).min(ins);
            }
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev.last().copied().unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances() {
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("ab", ""), 2);
        assert_eq!(edit_distance("stop", "stop"), 0);
        assert_eq!(edit_distance("stpo", "stop"), 2);
        assert_eq!(edit_distance("Motor", "motor"), 1);
        assert_eq!(edit_distance("zähler", "zahler"), 1, "chars, not bytes");
    }
}
