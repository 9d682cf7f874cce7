//! Composed covariance maps of the error-state filter (issue 14): the ops a
//! [`super::ekf::Covariance`] goes through over a stretch — propagations
//! `P ← Φ P Φᵀ + Q` and accepted updates `P ← P − P Hᵀ S⁻¹ H P` — are, for
//! a fixed sequence of `Φ, Q, H, R`, one map
//!
//! `f(P) = A (I + P J)⁻¹ P Aᵀ + C  ( = A (P⁻¹ + J)⁻¹ Aᵀ + C )`,
//!
//! the covariance part of the associative element of Särkkä and
//! García-Fernández (2021, "Temporal parallelization of Bayesian
//! smoothers", IEEE TAC 66(1): the covariance part of the filtering elements).
//! [`Element`] builds it by a forward recursion from the identity map
//! (`A = I`, `C = 0`, `J = 0`): appending a propagation gives `ΦA`,
//! `Φ C Φᵀ + Q`, `J`; appending an update with `(H, R)` is the
//! composition with the element `(I, 0, HᵀR⁻¹H)`, which by the
//! composition rule `A₁₂ = A₂ (I + C₁ J₂)⁻¹ A₁`,
//! `C₁₂ = A₂ (I + C₁ J₂)⁻¹ C₁ A₂ᵀ + C₂`,
//! `J₁₂ = A₁ᵀ (I + J₂ C₁)⁻¹ J₂ A₁ + J₁` and the matrix inversion lemma is
//! (`S = R + H C Hᵀ`, `K = C Hᵀ S⁻¹`, all with the old `A`, `C`):
//! `J ← J + (HA)ᵀ S⁻¹ (HA)`, `A ← A − K (HA)`, `C ← C − K H C`.
//! Applying the element to a prior costs one 21×21 solve and three
//! products, against a stretch's mechanization, propagations and updates.
//!
//! Since `(P⁻¹ + J)⁻¹ ≤ P`, the map is also bounded by `A P Aᵀ + C` in the
//! PSD order, which the planner's interior bounds use.

use nalgebra::{Const, DimMin, SMatrix, SVector, ToTypenum};

/// The map of a sequence of covariance ops on an `N`-state covariance (see
/// the module docs; the filter's is [`super::ekf::N`] = 21 states).
#[derive(Debug, Clone, PartialEq)]
pub struct Element<const N: usize> {
    /// A.
    pub a: SMatrix<f64, N, N>,
    /// C (symmetric).
    pub c: SMatrix<f64, N, N>,
    /// J (symmetric).
    pub j: SMatrix<f64, N, N>,
    /// Ops appended (propagations and accepted updates).
    pub ops: u64,
}

impl<const N: usize> Default for Element<N>
where
    Const<N>: DimMin<Const<N>, Output = Const<N>> + ToTypenum,
{
    fn default() -> Self {
        Self::identity()
    }
}

impl<const N: usize> Element<N>
where
    Const<N>: DimMin<Const<N>, Output = Const<N>> + ToTypenum,
{
    /// The identity map (no ops).
    pub fn identity() -> Self {
        Self {
            a: SMatrix::identity(),
            c: SMatrix::zeros(),
            j: SMatrix::zeros(),
            ops: 0,
        }
    }

    /// Appends `P ← Φ P Φᵀ + diag(q) t` with `Φ = I + Σ x e_i e_kᵀ` over the
    /// sparse entries `(i, k, x)` (already multiplied by `t`).
    pub fn propagate(&mut self, phi: &[(u8, u8, f64)], q: &SVector<f64, N>, t: f64) {
        // A ← Φ A: row i gains x × (old) row k.
        let a0 = self.a;
        for &(i, k, x) in phi {
            let (i, k) = (i as usize, k as usize);
            for col in 0..N {
                self.a[(i, col)] += x * a0[(k, col)];
            }
        }
        // C ← Φ C Φᵀ: D = C Φᵀ (columns), then Φ D = (D Φᵀ)ᵀ by symmetry.
        let mut d = self.c;
        for &(i, k, x) in phi {
            d.column_mut(i as usize)
                .axpy(x, &self.c.column(k as usize), 1.0);
        }
        let e = d.transpose();
        let mut c = e;
        for &(i, k, x) in phi {
            c.column_mut(i as usize).axpy(x, &e.column(k as usize), 1.0);
        }
        for i in 0..N {
            c[(i, i)] += q[i] * t;
        }
        self.c = (c + c.transpose()) * 0.5;
        self.ops += 1;
    }

    /// Appends an accepted update with rows `h` and noise `r`.
    pub fn update<const M: usize>(&mut self, h: &SMatrix<f64, M, N>, r: &SMatrix<f64, M, M>) {
        let hc = h * self.c;
        let s = r + hc * h.transpose();
        let Some(si) = nalgebra::Cholesky::new(s).map(|c| c.inverse()) else {
            return;
        };
        let ha = h * self.a;
        let k = hc.transpose() * si;
        self.j += ha.transpose() * si * ha;
        self.j = (self.j + self.j.transpose()) * 0.5;
        self.a -= k * ha;
        let c = self.c - k * hc;
        self.c = (c + c.transpose()) * 0.5;
        self.ops += 1;
    }

    /// `f(P)`: the covariance after the ops from `P`. The solve is on the
    /// diagonally scaled matrices (the error state mixes radians of
    /// latitude with metres per second): with `P = D P̃ D`,
    /// `(I + P J)⁻¹ P = D (I + P̃ J̃)⁻¹ P̃ D`, `J̃ = D J D`.
    pub fn apply(&self, p: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
        if self.ops == 0 {
            return *p;
        }
        let d: [f64; N] = std::array::from_fn(|i| {
            let x = p[(i, i)];
            if x > 0.0 {
                x.sqrt()
            } else {
                1.0
            }
        });
        let ps = SMatrix::<f64, N, N>::from_fn(|i, k| p[(i, k)] / (d[i] * d[k]));
        let js = SMatrix::<f64, N, N>::from_fn(|i, k| self.j[(i, k)] * d[i] * d[k]);
        let m = SMatrix::<f64, N, N>::identity() + ps * js;
        let w = match m.lu().solve(&ps) {
            Some(w) => SMatrix::<f64, N, N>::from_fn(|i, k| w[(i, k)] * d[i] * d[k]),
            None => *p,
        };
        let out = self.a * w * self.a.transpose() + self.c;
        (out + out.transpose()) * 0.5
    }

    /// The element of this one followed by `next`.
    pub fn then(&self, next: &Element<N>) -> Element<N> {
        // (I + C₁ J₂)⁻¹ applied to A₁ and to C₁.
        let m = SMatrix::<f64, N, N>::identity() + self.c * next.j;
        let lu = m.lu();
        let (Some(x), Some(y)) = (lu.solve(&self.a), lu.solve(&self.c)) else {
            return next.clone();
        };
        let a = next.a * x;
        let c = next.a * y * next.a.transpose() + next.c;
        // J₁₂ = A₁ᵀ (I + J₂ C₁)⁻¹ J₂ A₁ + J₁ = A₁ᵀ J₂ (I + C₁ J₂)⁻¹ A₁ + J₁.
        let j = self.a.transpose() * next.j * x + self.j;
        Element {
            a,
            c: (c + c.transpose()) * 0.5,
            j: (j + j.transpose()) * 0.5,
            ops: self.ops + next.ops,
        }
    }
}
