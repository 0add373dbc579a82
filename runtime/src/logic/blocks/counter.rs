//! Counters: CTU, CTD, CTUD (IEC 61131-3), counting rising edges, saturating at `i32` limits.

use super::Edge;

/// Up counter: each rising edge of `CU` adds one; `R` clears; `Q` is `CV >= PV`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Ctu {
    edge: Edge,
    cv: i32,
    q: bool,
}

impl Ctu {
    /// One call; returns `Q`.
    pub(crate) fn call(&mut self, cu: bool, reset: bool, pv: i32) -> bool {
        let up = self.edge.rising(cu);
        if reset {
            self.cv = 0;
        } else if up {
            self.cv = self.cv.saturating_add(1);
        }
        self.q = self.cv >= pv;
        self.q
    }

    /// The output.
    pub(crate) fn q(&self) -> bool {
        self.q
    }

    /// The count.
    pub(crate) fn cv(&self) -> i32 {
        self.cv
    }

    /// Sets the count (a retained or restored value).
    #[cfg(test)]
    pub(crate) fn set_cv(&mut self, cv: i32) {
        self.cv = cv;
    }
}

/// Down counter: `LD` loads `PV`; each rising edge of `CD` subtracts one; `Q` is `CV <= 0`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Ctd {
    edge: Edge,
    cv: i32,
    q: bool,
}

impl Ctd {
    /// One call; returns `Q`.
    pub(crate) fn call(&mut self, cd: bool, load: bool, pv: i32) -> bool {
        let down = self.edge.rising(cd);
        if load {
            self.cv = pv;
        } else if down {
            self.cv = self.cv.saturating_sub(1);
        }
        self.q = self.cv <= 0;
        self.q
    }

    /// The output.
    pub(crate) fn q(&self) -> bool {
        self.q
    }

    /// The count.
    pub(crate) fn cv(&self) -> i32 {
        self.cv
    }
}

/// Up-down counter: `R` clears (it wins over `LD`), `LD` loads `PV`, otherwise a rising edge
/// of `CU` adds one and one of `CD` subtracts one. `QU` is `CV >= PV`, `QD` is `CV <= 0`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Ctud {
    up: Edge,
    down: Edge,
    cv: i32,
    qu: bool,
    qd: bool,
}

impl Ctud {
    /// One call; returns `QU`.
    pub(crate) fn call(&mut self, cu: bool, cd: bool, reset: bool, load: bool, pv: i32) -> bool {
        let up = self.up.rising(cu);
        let down = self.down.rising(cd);
        if reset {
            self.cv = 0;
        } else if load {
            self.cv = pv;
        } else {
            if up {
                self.cv = self.cv.saturating_add(1);
            }
            if down {
                self.cv = self.cv.saturating_sub(1);
            }
        }
        self.qu = self.cv >= pv;
        self.qd = self.cv <= 0;
        self.qu
    }

    /// Counted up to the preset.
    pub(crate) fn qu(&self) -> bool {
        self.qu
    }

    /// Counted down to zero.
    pub(crate) fn qd(&self) -> bool {
        self.qd
    }

    /// The count.
    pub(crate) fn cv(&self) -> i32 {
        self.cv
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ctu_counts_edges_and_resets() {
        let mut c = Ctu::default();
        for x in [true, false, true, false, true, true] {
            c.call(x, false, 2);
        }
        // The first `true` is the first call: no edge.
        assert_eq!(c.cv(), 2);
        assert!(c.q());
        c.call(false, true, 2);
        assert_eq!((c.cv(), c.q()), (0, false));
        c.set_cv(i32::MAX);
        c.call(true, false, 2);
        assert_eq!(c.cv(), i32::MAX);
    }

    #[test]
    fn ctd_loads_and_counts_down() {
        let mut c = Ctd::default();
        c.call(false, true, 2);
        assert_eq!((c.cv(), c.q()), (2, false));
        for x in [true, false, true] {
            c.call(x, false, 2);
        }
        assert_eq!((c.cv(), c.q()), (0, true));
    }

    #[test]
    fn ctud_reset_wins_over_load() {
        let mut c = Ctud::default();
        c.call(false, false, false, true, 5);
        assert_eq!(c.cv(), 5);
        assert!(c.call(true, false, false, false, 5) && !c.qd());
        c.call(false, true, false, false, 5);
        c.call(false, false, false, false, 5);
        assert_eq!(c.cv(), 5);
        c.call(false, true, false, false, 5);
        assert_eq!(c.cv(), 4);
        c.call(false, false, true, true, 5);
        assert_eq!((c.cv(), c.qd()), (0, true));
    }
}
