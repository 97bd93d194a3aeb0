//! The not-a-knot cubic interpolating spline on 11 equally spaced knots,
//! precomputed as interpolation weights.
//!
//! simglucose interpolates its 15-minute CGM noise with scipy's
//! `interp1d(kind='cubic')`, which is the cubic interpolating spline with the
//! *not-a-knot* end conditions (the third derivative is continuous at the
//! second and the second-to-last knot, so the first two and the last two
//! pieces are each one cubic). A spline that interpolates is linear in the
//! knot values, and the CGM always evaluates it at the same positions, so
//! each output value is a fixed linear combination of the 11 knot values.
//! [`NotAKnotWeights`] computes those combinations once; evaluating is then
//! 11 multiply-adds and never allocates.
//!
//! Construction (knot spacing h = 1, knots x_i = i, values y_i, second
//! derivatives M_i; standard cubic-spline algebra, e.g. de Boor, *A Practical
//! Guide to Splines*, ch. IV):
//!
//! * continuity of the first derivative at the interior knots,
//!   M_{i−1} + 4 M_i + M_{i+1} = 6 (y_{i−1} − 2 y_i + y_{i+1}), i = 1..9;
//! * not-a-knot at x_1 and x_9: M_0 − 2 M_1 + M_2 = 0 and
//!   M_8 − 2 M_9 + M_10 = 0;
//! * on [i, i+1] with t = x − i:
//!   S(x) = (1−t) y_i + t y_{i+1} + ((1−t)³ − (1−t)) M_i/6 + (t³ − t) M_{i+1}/6.
//!
//! The 11×11 system is solved once per unit knot vector (Gaussian elimination
//! with partial pivoting), which gives the weights of every knot at every
//! requested position. At a knot the weights are exactly one unit vector, so
//! the spline passes through the knots bit for bit.

use crate::error::SimError;

/// Number of knots of the interpolation batch.
pub const KNOTS: usize = 11;

/// The not-a-knot spline through 11 knots at 0, 1, …, 10, evaluated at a
/// fixed list of positions, stored as one row of knot weights per position.
#[derive(Debug, Clone, PartialEq)]
pub struct NotAKnotWeights {
    rows: Vec<[f64; KNOTS]>,
}

impl NotAKnotWeights {
    /// Weights for the positions `positions`, in units of the knot spacing
    /// (each must lie in [0, 10]).
    pub fn new(positions: &[f64]) -> Result<Self, SimError> {
        if let Some(bad) = positions
            .iter()
            .find(|p| !(p.is_finite() && (0.0..=(KNOTS - 1) as f64).contains(*p)))
        {
            return Err(SimError::Config(format!(
                "spline position {bad} is outside the knot range [0, {}]",
                KNOTS - 1
            )));
        }
        // Second derivatives of the spline through each unit knot vector.
        let mut second = [[0.0; KNOTS]; KNOTS];
        for (k, m) in second.iter_mut().enumerate() {
            let mut y = [0.0; KNOTS];
            y[k] = 1.0;
            *m = second_derivatives(&y)?;
        }
        let rows = positions
            .iter()
            .map(|&x| {
                let mut row = [0.0; KNOTS];
                for (k, w) in row.iter_mut().enumerate() {
                    let mut y = [0.0; KNOTS];
                    y[k] = 1.0;
                    *w = evaluate_piece(&y, &second[k], x);
                }
                row
            })
            .collect();
        Ok(Self { rows })
    }

    /// How many positions there are.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Whether there are no positions.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// The knot weights of position `index` (panics if out of range).
    pub fn row(&self, index: usize) -> &[f64; KNOTS] {
        &self.rows[index]
    }

    /// The spline through `knots` at position `index` (panics if out of range).
    #[inline]
    pub fn evaluate(&self, index: usize, knots: &[f64; KNOTS]) -> f64 {
        self.rows[index].iter().zip(knots).map(|(w, y)| w * y).sum()
    }
}

/// The spline value at `x` given knot values `y` and second derivatives `m`.
fn evaluate_piece(y: &[f64; KNOTS], m: &[f64; KNOTS], x: f64) -> f64 {
    // Piece i covers [i, i+1]; x = 10 belongs to the last piece.
    let i = (x.floor() as usize).min(KNOTS - 2);
    let t = x - i as f64;
    let s = 1.0 - t;
    s * y[i] + t * y[i + 1] + (s * s * s - s) * m[i] / 6.0 + (t * t * t - t) * m[i + 1] / 6.0
}

/// Second derivatives at the knots of the not-a-knot spline through `y`.
fn second_derivatives(y: &[f64; KNOTS]) -> Result<[f64; KNOTS], SimError> {
    let n = KNOTS;
    let mut a = [[0.0; KNOTS]; KNOTS];
    let mut rhs = [0.0; KNOTS];
    // Not-a-knot at knot 1.
    a[0][0] = 1.0;
    a[0][1] = -2.0;
    a[0][2] = 1.0;
    // C1 continuity at the interior knots.
    for i in 1..n - 1 {
        a[i][i - 1] = 1.0;
        a[i][i] = 4.0;
        a[i][i + 1] = 1.0;
        rhs[i] = 6.0 * (y[i - 1] - 2.0 * y[i] + y[i + 1]);
    }
    // Not-a-knot at knot n-2.
    a[n - 1][n - 3] = 1.0;
    a[n - 1][n - 2] = -2.0;
    a[n - 1][n - 1] = 1.0;
    solve(a, rhs)
}

/// Solves `a x = b` by Gaussian elimination with partial pivoting.
fn solve(mut a: [[f64; KNOTS]; KNOTS], mut b: [f64; KNOTS]) -> Result<[f64; KNOTS], SimError> {
    let n = KNOTS;
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap_or(col);
        if a[pivot][col].abs() < 1e-12 {
            return Err(SimError::Config(
                "not-a-knot spline system is singular (internal error)".into(),
            ));
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in col + 1..n {
            let f = a[row][col] / a[col][col];
            if f != 0.0 {
                let pivot_row = a[col];
                for (x, p) in a[row][col..].iter_mut().zip(&pivot_row[col..]) {
                    *x -= f * p;
                }
                b[row] -= f * b[col];
            }
        }
    }
    let mut x = [0.0; KNOTS];
    for row in (0..n).rev() {
        let tail: f64 = (row + 1..n).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - tail) / a[row][row];
    }
    Ok(x)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_one_and_are_unit_vectors_at_knots() {
        let positions: Vec<f64> = (0..=30).map(|j| j as f64 / 3.0).collect();
        let w = NotAKnotWeights::new(&positions).unwrap();
        for (j, &x) in positions.iter().enumerate() {
            let sum: f64 = w.row(j).iter().sum();
            assert!(
                (sum - 1.0).abs() < 1e-13,
                "position {x}: weights sum to {sum}"
            );
            if j % 3 == 0 {
                let mut unit = [0.0; KNOTS];
                unit[j / 3] = 1.0;
                assert_eq!(w.row(j), &unit, "position {x}");
            }
        }
    }

    #[test]
    fn rejects_positions_outside_the_knots() {
        assert!(NotAKnotWeights::new(&[10.5]).is_err());
        assert!(NotAKnotWeights::new(&[-0.1]).is_err());
        assert!(NotAKnotWeights::new(&[f64::NAN]).is_err());
    }
}
