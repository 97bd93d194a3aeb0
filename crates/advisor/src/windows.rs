//! Data windows of the daily timeline (spec §2): one per calendar day (basal
//! updates) and one per main meal, from its announcement to the next main-meal
//! announcement that actually happened (carb-ratio updates).
//!
//! Windows hold running accumulators, never the readings themselves, so
//! memory stays constant however long a window runs.

use abba_core::Timestamp;
use serde::{Deserialize, Serialize};

/// Accumulators of the two most recent calendar days (readings at 00:00 of
/// the next day can arrive before that day's `DayClosed`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DayWindows<A> {
    current: Option<(i64, A)>,
    previous: Option<(i64, A)>,
}

impl<A> Default for DayWindows<A> {
    fn default() -> Self {
        Self {
            current: None,
            previous: None,
        }
    }
}

impl<A: Default> DayWindows<A> {
    /// The accumulator of calendar day `day` (days only move forward).
    pub fn day_mut(&mut self, day: i64) -> &mut A {
        match self.current.as_ref().map(|(d, _)| *d) {
            Some(d) if d == day => {}
            Some(d) if d > day => {
                // An older day than the current one can only be the previous one.
                if self.previous.as_ref().map(|(p, _)| *p) != Some(day) {
                    self.previous = None;
                }
                return &mut self.previous.get_or_insert_with(|| (day, A::default())).1;
            }
            _ => {
                self.previous = self.current.take();
            }
        }
        &mut self.current.get_or_insert_with(|| (day, A::default())).1
    }

    /// True when no day is open.
    pub fn is_empty(&self) -> bool {
        self.current.is_none() && self.previous.is_none()
    }

    /// Removes and returns the accumulator of `day`, dropping any older one.
    pub fn close(&mut self, day: i64) -> Option<A> {
        let mut out = None;
        for slot in [&mut self.previous, &mut self.current] {
            if let Some((d, _)) = slot {
                if *d <= day {
                    if let Some((d, a)) = slot.take() {
                        if d == day {
                            out = Some(a);
                        }
                    }
                }
            }
        }
        out
    }
}

/// A finished meal window.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DoneWindow<A> {
    /// Day index of the announcement that opened it.
    pub day: i64,
    /// When it opened (the announcement).
    pub start: Timestamp,
    /// When it closed (the next main-meal announcement).
    pub end: Timestamp,
    /// Its accumulator.
    pub acc: A,
}

/// The open meal window and the last finished window of each main meal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MealWindows<A> {
    open: Option<(usize, i64, Timestamp, A)>,
    done: [Option<DoneWindow<A>>; 3],
}

impl<A> Default for MealWindows<A> {
    fn default() -> Self {
        Self {
            open: None,
            done: [None, None, None],
        }
    }
}

impl<A: Default> MealWindows<A> {
    /// The open window's (start, accumulator), if a main meal was announced.
    pub fn open_mut(&mut self) -> Option<(Timestamp, &mut A)> {
        self.open.as_mut().map(|(_, _, start, a)| (*start, a))
    }

    /// Main meal `slot` (0..3) announced at `at`: closes the open window,
    /// opens a new one for `slot`, and returns window `slot` of the previous
    /// calendar day if it exists (None if that meal was skipped or not seen).
    pub fn announce(&mut self, slot: usize, at: Timestamp) -> Option<DoneWindow<A>> {
        if let Some((s, day, start, acc)) = self.open.take() {
            self.done[s] = Some(DoneWindow {
                day,
                start,
                end: at,
                acc,
            });
        }
        let day = at.day_index();
        let prev = self.done[slot].take().filter(|w| w.day == day - 1);
        self.open = Some((slot, day, at, A::default()));
        prev
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn day_windows_keep_the_closing_day_apart_from_the_next() {
        let mut d: DayWindows<u32> = DayWindows::default();
        *d.day_mut(7) += 3;
        *d.day_mut(8) += 1; // a 00:00 reading before D8's close
        assert_eq!(d.close(7), Some(3));
        assert_eq!(d.close(8), Some(1));
        assert_eq!(d.close(8), None);
        *d.day_mut(10) += 1;
        assert_eq!(d.close(9), None, "an empty day has no window");
        assert_eq!(d.close(10), Some(1));
    }

    #[test]
    fn skipped_meal_extends_previous_window_and_skips_its_update() {
        let mut m: MealWindows<u32> = MealWindows::default();
        let t = |day: i64, min: i64| Timestamp::from_day_and_minute(day, min);
        assert!(m.announce(0, t(1, 420)).is_none());
        *m.open_mut().unwrap().1 += 1; // reading in breakfast window
                                       // lunch skipped on day 1; dinner closes the breakfast window
        assert!(m.announce(2, t(1, 1110)).is_none());
        *m.open_mut().unwrap().1 += 5;
        let w = m.announce(0, t(2, 420)).unwrap();
        assert_eq!((w.day, w.acc, w.end), (1, 1, t(1, 1110)));
        assert!(
            m.announce(1, t(2, 720)).is_none(),
            "lunch of day 1 was skipped"
        );
        let w = m.announce(2, t(2, 1110)).unwrap();
        assert_eq!(
            (w.day, w.acc),
            (1, 5),
            "dinner window ran to next breakfast"
        );
    }
}
