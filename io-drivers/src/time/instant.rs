//! The instant types, one per clock (see the [`time`](super) namespace for what each means).

use std::fmt;
use std::ops::{Add, AddAssign, Sub, SubAssign};
use std::time::Duration;

use super::fmt_duration;

/// One instant type for one clock: the same arithmetic, a distinct type.
macro_rules! instant_on_clock {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub struct $name(Duration);

        impl $name {
            /// The clock's origin.
            pub const ZERO: Self = Self(Duration::ZERO);

            /// The instant `since_origin` after the clock's origin.
            pub const fn after_origin(since_origin: Duration) -> Self {
                Self(since_origin)
            }

            /// The time from the clock's origin to this instant.
            pub const fn since_origin(self) -> Duration {
                self.0
            }

            /// The time from `earlier` to `self`; `None` when `earlier` is in fact later.
            pub fn checked_duration_since(self, earlier: Self) -> Option<Duration> {
                self.0.checked_sub(earlier.0)
            }

            /// The time from `earlier` to `self`; zero when `earlier` is in fact later.
            pub fn saturating_duration_since(self, earlier: Self) -> Duration {
                self.0.saturating_sub(earlier.0)
            }

            /// `d` later; `None` past the far end of time.
            pub fn checked_add(self, d: Duration) -> Option<Self> {
                self.0.checked_add(d).map(Self)
            }

            /// `d` earlier; `None` before the clock's origin.
            pub fn checked_sub(self, d: Duration) -> Option<Self> {
                self.0.checked_sub(d).map(Self)
            }
        }

        /// Saturates at the far end of time ([`Duration::MAX`] after the origin).
        impl Add<Duration> for $name {
            type Output = Self;
            fn add(self, d: Duration) -> Self {
                Self(self.0.saturating_add(d))
            }
        }

        impl AddAssign<Duration> for $name {
            fn add_assign(&mut self, d: Duration) {
                *self = *self + d;
            }
        }

        /// Saturates at the clock's origin.
        impl Sub<Duration> for $name {
            type Output = Self;
            fn sub(self, d: Duration) -> Self {
                Self(self.0.saturating_sub(d))
            }
        }

        impl SubAssign<Duration> for $name {
            fn sub_assign(&mut self, d: Duration) {
                *self = *self - d;
            }
        }

        /// The time between two instants; zero when the right one is in fact later (see
        /// [`checked_duration_since`](Self::checked_duration_since) to tell).
        impl Sub for $name {
            type Output = Duration;
            fn sub(self, earlier: Self) -> Duration {
                self.saturating_duration_since(earlier)
            }
        }

        /// As a person reads it (`12.35ms`), like every time softplc prints; width and
        /// alignment apply (`{:>7}`).
        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.pad(&fmt_duration(self.0))
            }
        }

        /// The time since the origin, exact (as [`Duration`]'s own `Debug` prints it), so a
        /// struct's debug output stays what it was before the instants had their own types.
        impl fmt::Debug for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                fmt::Debug::fmt(&self.0, f)
            }
        }
    };
}

instant_on_clock! {
    /// A point in time on the scan's clock: time since the PLC started, on its
    /// [`Clock`](super::Clock) (real or virtual). A cycle's start and deadlines, what logic sees
    /// as `now`, the process image's timestamps, the trace and the record count on it.
    ScanInstant
}

instant_on_clock! {
    /// A point in time on a line's own clock: what its transport answers to `now()`, when a
    /// frame left and its reply ended, the simulated world's time. On the real clock it is the
    /// PLC's time; on a virtual clock the line's own cursor, which may run ahead of the scan.
    LineInstant
}

impl ScanInstant {
    /// The same point on a line's clock. Used where the scan tells a line what time it is
    /// (`BusOwner::sync`) and where a real-time line reads the PLC's clock.
    pub const fn on_line_clock(self) -> LineInstant {
        LineInstant(self.0)
    }
}

impl LineInstant {
    /// The same point on the scan's clock. Used where the scan takes a line's answer at the
    /// time it ended (a line the scan runs itself, or a real-time line, keeps the PLC's time).
    pub const fn on_scan_clock(self) -> ScanInstant {
        ScanInstant(self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn later_minus_earlier_is_the_time_between() {
        let a = ScanInstant::after_origin(ms(5));
        let b = a + ms(7);
        assert_eq!(b - a, ms(7));
        assert_eq!(b.checked_duration_since(a), Some(ms(7)));
        assert_eq!(b.since_origin(), ms(12));
    }

    #[test]
    fn earlier_minus_later_is_zero_or_none() {
        let a = LineInstant::after_origin(ms(5));
        let b = LineInstant::after_origin(ms(9));
        assert_eq!(a - b, Duration::ZERO);
        assert_eq!(a.checked_duration_since(b), None);
        assert_eq!(a.saturating_duration_since(b), Duration::ZERO);
    }

    #[test]
    fn adding_past_the_end_of_time_saturates_or_is_none() {
        let near_end = ScanInstant::after_origin(Duration::MAX - ms(1));
        assert_eq!(near_end + ms(2), ScanInstant::after_origin(Duration::MAX));
        assert_eq!(near_end.checked_add(ms(2)), None);
        assert_eq!(
            near_end.checked_add(ms(1)),
            Some(ScanInstant::after_origin(Duration::MAX))
        );
        let mut t = near_end;
        t += Duration::MAX;
        assert_eq!(t.since_origin(), Duration::MAX);
    }

    #[test]
    fn subtracting_before_the_origin_saturates_or_is_none() {
        let t = LineInstant::after_origin(ms(3));
        assert_eq!(t - ms(5), LineInstant::ZERO);
        assert_eq!(t.checked_sub(ms(5)), None);
        assert_eq!(t.checked_sub(ms(3)), Some(LineInstant::ZERO));
        let mut u = t;
        u -= ms(1);
        assert_eq!(u, LineInstant::after_origin(ms(2)));
    }

    #[test]
    fn instants_order_by_time() {
        let a = ScanInstant::after_origin(ms(1));
        let b = ScanInstant::after_origin(ms(2));
        assert!(a < b);
        assert_eq!(a.max(b), b);
        assert_eq!(ScanInstant::default(), ScanInstant::ZERO);
    }

    #[test]
    fn mapping_between_clocks_keeps_the_time() {
        let t = ScanInstant::after_origin(Duration::new(3, 7));
        assert_eq!(t.on_line_clock().since_origin(), Duration::new(3, 7));
        assert_eq!(t.on_line_clock().on_scan_clock(), t);
    }

    #[test]
    fn prints_as_a_person_reads_and_debugs_as_the_duration() {
        let t = ScanInstant::after_origin(Duration::from_micros(12_345));
        assert_eq!(t.to_string(), "12.35ms");
        assert_eq!(
            format!("{t:?}"),
            format!("{:?}", Duration::from_micros(12_345))
        );
        assert_eq!(
            LineInstant::after_origin(Duration::from_micros(850)).to_string(),
            "850µs"
        );
    }
}
