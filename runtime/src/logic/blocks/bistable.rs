//! Bistables: SR (set wins), RS (reset wins) and TOGGLE, an impulse relay.

use super::Edge;

/// Set-dominant latch: `Q := S1 or (Q and not R)`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Sr {
    q: bool,
}

impl Sr {
    /// One call; returns `Q`.
    pub(crate) fn call(&mut self, set: bool, reset: bool) -> bool {
        self.q = set || (self.q && !reset);
        self.q
    }

    /// The output.
    pub(crate) fn q(&self) -> bool {
        self.q
    }
}

/// Reset-dominant latch: `Q := not R1 and (S or Q)`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Rs {
    q: bool,
}

impl Rs {
    /// One call; returns `Q`.
    pub(crate) fn call(&mut self, set: bool, reset: bool) -> bool {
        self.q = !reset && (set || self.q);
        self.q
    }

    /// The output.
    pub(crate) fn q(&self) -> bool {
        self.q
    }
}

/// Impulse relay: each rising edge of the input flips `Q`; the reset input clears it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Toggle {
    edge: Edge,
    q: bool,
}

impl Toggle {
    /// One call; returns `Q`.
    pub(crate) fn call(&mut self, input: bool, reset: bool) -> bool {
        let edge = self.edge.rising(input);
        if reset {
            self.q = false;
        } else if edge {
            self.q = !self.q;
        }
        self.q
    }

    /// The output.
    pub(crate) fn q(&self) -> bool {
        self.q
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dominance() {
        let mut sr = Sr::default();
        assert!(sr.call(true, true));
        assert!(sr.call(false, false));
        assert!(!sr.call(false, true));
        let mut rs = Rs::default();
        assert!(!rs.call(true, true));
        assert!(rs.call(true, false));
        assert!(rs.call(false, false));
        assert!(!rs.call(false, true));
    }

    #[test]
    fn toggle_flips_on_rising_edges() {
        let mut t = Toggle::default();
        let out: Vec<bool> = [false, true, true, false, true, false]
            .into_iter()
            .map(|x| t.call(x, false))
            .collect();
        assert_eq!(out, [false, true, true, true, false, false]);
        t.call(true, false);
        assert!(t.q());
        assert!(!t.call(false, true));
    }
}
