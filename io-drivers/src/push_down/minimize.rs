//! Exact minimal sum of products over at most three variables.
//!
//! A MiniMod output has three ON and three OFF condition masks, each a product of input
//! literals ("Automatic output management"): a condition fits when its minimal sum of products
//! has at most three terms. With three variables there are only 3³ = 27 product terms, so the
//! minimiser is exact by enumeration: list the prime implicants, then try every set of primes,
//! smallest first (fewest terms, then fewest literals). Don't-care input combinations may be
//! covered or not, whichever gives the smaller sum.

/// Most variables the minimiser takes (the MiniMod's X1..X3).
pub(crate) const MAX_VARS: u8 = 3;

/// A product term. Variable `i` appears when bit `i` of `care` is set, un-negated when bit `i`
/// of `value` is also set. The empty product (`care == 0`) is always true.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) struct Cube {
    /// The variables in the term.
    pub care: u8,
    /// Their polarity (a subset of `care`).
    pub value: u8,
}

impl Cube {
    /// Whether the term is true for the input combination `minterm` (variable `i` = bit `i`).
    pub(crate) fn covers(self, minterm: u8) -> bool {
        minterm & self.care == self.value
    }

    /// Number of literals.
    pub(crate) fn literals(self) -> u32 {
        self.care.count_ones()
    }

    /// The set of input combinations (over `vars` variables) the term is true for, as bits.
    pub(crate) fn minterms(self, vars: u8) -> u8 {
        (0..(1u8 << vars.min(MAX_VARS)))
            .filter(|&m| self.covers(m))
            .fold(0, |acc, m| acc | (1 << m))
    }
}

/// Why the minimiser refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub(crate) enum MinimizeError {
    /// More variables than it handles.
    #[error("{vars} variables: the minimiser takes at most {MAX_VARS}")]
    TooManyVariables {
        /// How many were asked for.
        vars: u8,
    },
}

/// The truth table of `f` over `vars` variables: bit `m` is `f(m)`.
#[cfg(test)]
pub(crate) fn truth_table(vars: u8, mut f: impl FnMut(u8) -> bool) -> Result<u8, MinimizeError> {
    if vars > MAX_VARS {
        return Err(MinimizeError::TooManyVariables { vars });
    }
    Ok((0..(1u8 << vars))
        .filter(|&m| f(m))
        .fold(0, |acc, m| acc | (1 << m)))
}

/// A minimal sum of products over `vars` variables that is true on every combination of `on`,
/// false on every combination outside `on | dc`, and free on `dc` (bit `m` of a table is the
/// combination `m`). Minimal: fewest terms, then fewest literals; ties are broken the same way
/// every time. An empty result is the constant false; `[Cube { care: 0, value: 0 }]` the
/// constant true.
pub(crate) fn minimize(on: u8, dc: u8, vars: u8) -> Result<Vec<Cube>, MinimizeError> {
    if vars > MAX_VARS {
        return Err(MinimizeError::TooManyVariables { vars });
    }
    let full = ((1u16 << (1u16 << vars)) - 1) as u8;
    let on = on & full;
    let allowed = (on | dc) & full;
    if on == 0 {
        return Ok(Vec::new());
    }
    // Every implicant: a term true only where the function may be true.
    let mut implicants: Vec<(Cube, u8)> = Vec::new();
    for care in 0..(1u8 << vars) {
        let mut value = care;
        loop {
            let cube = Cube { care, value };
            let covered = cube.minterms(vars);
            if covered & !allowed == 0 {
                implicants.push((cube, covered));
            }
            if value == 0 {
                break;
            }
            value = (value - 1) & care;
        }
    }
    // Primes: not contained in a larger implicant; only those that cover an ON combination help.
    let primes: Vec<(Cube, u8)> = implicants
        .iter()
        .copied()
        .filter(|&(_, c)| c & on != 0 && !implicants.iter().any(|&(_, d)| d != c && d & c == c))
        .collect();
    let mut best: Option<(u32, u32, Vec<Cube>)> = None;
    // At most 2^|primes| subsets; three variables have few primes (a handful, with don't-cares
    // at most 12), so this is small.
    let n = primes.len().min(16);
    for subset in 1u32..(1u32 << n) {
        let terms = subset.count_ones();
        if best.as_ref().is_some_and(|(t, _, _)| terms > *t) {
            continue;
        }
        let mut covered = 0u8;
        let mut literals = 0;
        let mut cubes = Vec::with_capacity(terms as usize);
        for (i, &(cube, c)) in primes.iter().enumerate().take(n) {
            if subset & (1 << i) != 0 {
                covered |= c;
                literals += cube.literals();
                cubes.push(cube);
            }
        }
        if covered & on != on {
            continue;
        }
        cubes.sort();
        let better = match &best {
            None => true,
            Some((t, l, b)) => (terms, literals, &cubes) < (*t, *l, b),
        };
        if better {
            best = Some((terms, literals, cubes));
        }
    }
    Ok(best.map(|(_, _, c)| c).unwrap_or_default())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every product term over three variables with the set of combinations it covers.
    fn all_cubes() -> Vec<(Cube, u8)> {
        let mut out = Vec::new();
        for care in 0..8u8 {
            for value in 0..8u8 {
                if value & !care == 0 {
                    let c = Cube { care, value };
                    out.push((c, c.minterms(3)));
                }
            }
        }
        out
    }

    /// Brute force: the fewest terms, then the fewest literals, of any sum of products equal
    /// to the function (free on `dc`), by breadth-first search over sets of covered
    /// combinations using every implicant.
    fn brute(on: u8, dc: u8) -> (u32, u32) {
        let allowed = on | dc;
        let implicants: Vec<(Cube, u8)> = all_cubes()
            .into_iter()
            .filter(|&(_, c)| c & !allowed == 0)
            .collect();
        if on == 0 {
            return (0, 0);
        }
        // layer[s] = fewest literals of a sum of `k` terms covering exactly s.
        let mut layer: Vec<Option<u32>> = vec![None; 256];
        layer[0] = Some(0);
        for k in 1..=8u32 {
            let mut next: Vec<Option<u32>> = vec![None; 256];
            for (s, lits) in layer.iter().enumerate() {
                let Some(lits) = lits else { continue };
                for &(cube, c) in &implicants {
                    let t = s | usize::from(c);
                    let l = lits + cube.literals();
                    if next[t].is_none_or(|old| l < old) {
                        next[t] = Some(l);
                    }
                }
            }
            let done = next
                .iter()
                .enumerate()
                .filter(|(s, l)| l.is_some() && (*s as u8) & on == on)
                .filter_map(|(_, l)| *l)
                .min();
            if let Some(l) = done {
                return (k, l);
            }
            layer = next;
        }
        unreachable!("every function has a sum of products")
    }

    fn check(on: u8, dc: u8) {
        let cover = minimize(on, dc, 3).unwrap();
        for m in 0..8u8 {
            let value = cover.iter().any(|c| c.covers(m));
            if on & (1 << m) != 0 {
                assert!(value, "on {on:08b} dc {dc:08b}: misses {m}");
            } else if dc & (1 << m) == 0 {
                assert!(!value, "on {on:08b} dc {dc:08b}: covers {m}");
            }
        }
        let terms = cover.len() as u32;
        let literals: u32 = cover.iter().map(|c| c.literals()).sum();
        assert_eq!(
            (terms, literals),
            brute(on, dc),
            "on {on:08b} dc {dc:08b}: {cover:?}"
        );
    }

    #[test]
    fn every_function_of_three_variables_is_minimal() {
        for on in 0..=255u8 {
            check(on, 0);
        }
    }

    #[test]
    fn every_function_with_dont_cares_is_minimal() {
        // Every (on, dc) pair with disjoint sets: 3^8 = 6561 incompletely specified functions.
        for code in 0..6561u32 {
            let (mut on, mut dc, mut c) = (0u8, 0u8, code);
            for m in 0..8 {
                match c % 3 {
                    1 => on |= 1 << m,
                    2 => dc |= 1 << m,
                    _ => {}
                }
                c /= 3;
            }
            check(on, dc);
        }
    }

    #[test]
    fn fewer_variables_and_constants() {
        assert_eq!(minimize(0, 0, 3), Ok(vec![]));
        assert_eq!(minimize(0xFF, 0, 3), Ok(vec![Cube { care: 0, value: 0 }]));
        // x0 & !x1 over two variables: combination 1 only.
        assert_eq!(
            minimize(0b0010, 0, 2),
            Ok(vec![Cube {
                care: 0b11,
                value: 0b01
            }])
        );
        // Bits beyond the variables' combinations are ignored.
        assert_eq!(minimize(0b1111_0010, 0, 2), minimize(0b0010, 0, 2));
        assert_eq!(
            minimize(1, 0, 4),
            Err(MinimizeError::TooManyVariables { vars: 4 })
        );
        // Three-input parity needs four terms.
        let parity = truth_table(3, |m| m.count_ones() % 2 == 1).unwrap();
        assert_eq!(minimize(parity, 0, 3).unwrap().len(), 4);
    }
}
