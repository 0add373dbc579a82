//! The edit distance behind every "did you mean" hint: the project file's names and keys, the
//! web page's tags, the logic compilers' tags, functions and blocks, and a scenario's tags.
//! One function, so a typo is measured the same way wherever it is made; [`close_to`] is the
//! rule of which candidates are close enough, for callers that have no rule of their own.

/// Edit distance over chars: insertions, deletions, substitutions and the swap of two
/// neighbours each cost 1 (the optimal string alignment distance), so `retian` is one edit
/// from `retain`, as a typist makes it.
pub(crate) fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    // Three rows: the one before the last (for a swap), the last, and the one being filled.
    let mut before: Vec<usize> = vec![0; b.len() + 1];
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0; b.len() + 1];
    for (i, &ca) in a.iter().enumerate() {
        if let Some(first) = cur.first_mut() {
            *first = i + 1;
        }
        for (j, &cb) in b.iter().enumerate() {
            let subst = prev.get(j).copied().unwrap_or(0) + usize::from(ca != cb);
            let del = prev.get(j + 1).copied().unwrap_or(0) + 1;
            let ins = cur.get(j).copied().unwrap_or(0) + 1;
            let mut best = subst.min(del).min(ins);
            let swapped = i > 0
                && j > 0
                && a.get(i - 1) == Some(&cb)
                && b.get(j - 1) == Some(&ca)
                && ca != cb;
            if swapped {
                best = best.min(before.get(j - 1).copied().unwrap_or(0) + 1);
            }
            if let Some(c) = cur.get_mut(j + 1) {
                *c = best;
            }
        }
        std::mem::swap(&mut before, &mut prev);
        std::mem::swap(&mut prev, &mut cur);
    }
    prev.last().copied().unwrap_or(0)
}

/// The candidates close enough to `wanted` to suggest, closest first, at most `max`: one that
/// differs only in (ASCII) case alone; else those within one edit of a name of up to four
/// characters, two of a longer one, case aside.
pub(crate) fn close_to<'a>(
    wanted: &str,
    candidates: impl IntoIterator<Item = &'a str>,
    max: usize,
) -> Vec<&'a str> {
    let candidates: Vec<&'a str> = candidates.into_iter().collect();
    if let Some(&same) = candidates.iter().find(|n| n.eq_ignore_ascii_case(wanted)) {
        return vec![same];
    }
    let limit = if wanted.chars().count() > 4 { 2 } else { 1 };
    let upper = wanted.to_ascii_uppercase();
    let mut scored: Vec<(usize, &'a str)> = candidates
        .into_iter()
        .filter_map(|name| {
            let d = edit_distance(&upper, &name.to_ascii_uppercase());
            (d <= limit).then_some((d, name))
        })
        .collect();
    scored.sort_by_key(|&(d, _)| d);
    scored.into_iter().take(max).map(|(_, n)| n).collect()
}

/// `; did you mean `x`?` (or `x` or `y`, equally close) for the closest candidates to `wanted`
/// that [`close_to`] finds; empty when none is.
pub(crate) fn did_you_mean<'a>(
    wanted: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> String {
    let upper = wanted.to_ascii_uppercase();
    let distance = |name: &str| edit_distance(&upper, &name.to_ascii_uppercase());
    let close = close_to(wanted, candidates, 3);
    let Some(best) = close.first().map(|n| distance(n)) else {
        return String::new();
    };
    let names: Vec<String> = close
        .iter()
        .filter(|n| distance(n) == best)
        .map(|n| format!("`{n}`"))
        .collect();
    format!("; did you mean {}?", names.join(" or "))
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
        assert_eq!(edit_distance("Motor", "motor"), 1);
        assert_eq!(edit_distance("zähler", "zahler"), 1, "chars, not bytes");
    }

    #[test]
    fn two_neighbours_swapped_are_one_edit() {
        assert_eq!(edit_distance("retian", "retain"), 1);
        assert_eq!(edit_distance("stpo", "stop"), 1);
        assert_eq!(edit_distance("ab", "ba"), 1);
        assert_eq!(
            edit_distance("abc", "ca"),
            3,
            "no edit twice over one place"
        );
    }

    #[test]
    fn close_candidates_closest_first() {
        let keys = ["name", "point", "safe", "retain", "offload", "initial"];
        assert_eq!(close_to("retian", keys, 3), ["retain"]);
        assert_eq!(close_to("NAME", keys, 3), ["name"], "case alone");
        assert_eq!(close_to("pint", keys, 3), ["point"]);
        assert!(close_to("xyz", keys, 3).is_empty());
        assert_eq!(did_you_mean("retian", keys), "; did you mean `retain`?");
        assert_eq!(did_you_mean("xyz", keys), "");
        // Only the closest: `adress` is one edit from `address`, two from `access`.
        assert_eq!(
            did_you_mean("adress", ["address", "access"]),
            "; did you mean `address`?"
        );
        assert_eq!(
            did_you_mean("Y9", ["Y1", "Y2"]),
            "; did you mean `Y1` or `Y2`?"
        );
    }
}
