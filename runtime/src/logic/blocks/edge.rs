//! R_TRIG and F_TRIG: one-scan pulses on a change of the input.

/// Edge detector. The first call has no previous input and sees no edge.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Edge {
    prev: Option<bool>,
    q: bool,
}

impl Edge {
    /// True on the call where `x` is true and was false on the previous call.
    pub(crate) fn rising(&mut self, x: bool) -> bool {
        self.q = x && self.prev == Some(false);
        self.prev = Some(x);
        self.q
    }

    /// True on the call where `x` is false and was true on the previous call.
    pub(crate) fn falling(&mut self, x: bool) -> bool {
        self.q = !x && self.prev == Some(true);
        self.prev = Some(x);
        self.q
    }

    /// The last result.
    pub(crate) fn q(&self) -> bool {
        self.q
    }
}

/// R_TRIG: an edge detector called for rising edges.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct RTrig(pub Edge);

/// F_TRIG: an edge detector called for falling edges.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct FTrig(pub Edge);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_need_a_previous_value() {
        let mut r = Edge::default();
        let seen: Vec<bool> = [true, false, true, true, false]
            .into_iter()
            .map(|x| r.rising(x))
            .collect();
        assert_eq!(seen, [false, false, true, false, false]);
        let mut f = Edge::default();
        let seen: Vec<bool> = [false, true, false, false]
            .into_iter()
            .map(|x| f.falling(x))
            .collect();
        assert_eq!(seen, [false, false, true, false]);
        assert!(!f.q());
    }
}
