//! The eating queue: announced carbohydrate is eaten at 5 g/min
//! (simglucose's `EAT_RATE`; `spec/uva-padova-model.md` §1.4).

use serde::{Deserialize, Serialize};

/// simglucose's eating rate (g/min).
pub const EAT_RATE_G_PER_MIN: f64 = 5.0;

/// Carbohydrate announced but not yet eaten.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct EatingQueue {
    planned_g: f64,
}

impl EatingQueue {
    /// An empty queue.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a meal of `grams` (must be finite and >= 0; the caller validates).
    pub fn add(&mut self, grams: f64) {
        self.planned_g += grams;
    }

    /// Grams eaten during this minute: min(5, queue), taken off the queue.
    pub fn eat_minute(&mut self) -> f64 {
        let eaten = self.planned_g.min(EAT_RATE_G_PER_MIN);
        self.planned_g -= eaten;
        if self.planned_g < 1e-12 {
            // Rounding residue of repeated subtraction, not food.
            self.planned_g = 0.0;
        }
        eaten
    }

    /// Grams still to eat.
    pub fn pending_g(&self) -> f64 {
        self.planned_g
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meals_are_eaten_at_five_grams_per_minute() {
        let mut q = EatingQueue::new();
        q.add(52.0);
        let eaten: Vec<f64> = (0..12).map(|_| q.eat_minute()).collect();
        assert_eq!(&eaten[..10], &[5.0; 10]);
        assert!((eaten[10] - 2.0).abs() < 1e-12);
        assert_eq!(eaten[11], 0.0);
    }
}
