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
        // A ← Φ A: row i gains x × (old) row k; as columns of Aᵀ.
        let at0 = self.a.transpose();
        let mut at = at0;
        for &(i, k, x) in phi {
            at.column_mut(i as usize)
                .axpy(x, &at0.column(k as usize), 1.0);
        }
        at.transpose_to(&mut self.a);
        // C ← Φ C Φᵀ: D = C Φᵀ (columns), then Φ D = (D Φᵀ)ᵀ by symmetry.
        let mut d = self.c;
        for &(i, k, x) in phi {
            d.column_mut(i as usize)
                .axpy(x, &self.c.column(k as usize), 1.0);
        }
        let e = d.transpose();
        self.c = e;
        for &(i, k, x) in phi {
            self.c
                .column_mut(i as usize)
                .axpy(x, &e.column(k as usize), 1.0);
        }
        for i in 0..N {
            self.c[(i, i)] += q[i] * t;
        }
        self.c.fill_upper_triangle_with_lower_triangle();
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
        // J is symmetrized once, in `apply` and `then` (its updates are
        // symmetric up to round-off).
        self.j += ha.transpose() * (si * ha);
        self.a -= k * ha;
        self.c -= k * hc;
        self.c.fill_upper_triangle_with_lower_triangle();
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
        let js = SMatrix::<f64, N, N>::from_fn(|i, k| {
            0.5 * (self.j[(i, k)] + self.j[(k, i)]) * d[i] * d[k]
        });
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
        let j2 = (next.j + next.j.transpose()) * 0.5;
        let m = SMatrix::<f64, N, N>::identity() + self.c * j2;
        let lu = m.lu();
        let (Some(x), Some(y)) = (lu.solve(&self.a), lu.solve(&self.c)) else {
            return next.clone();
        };
        let a = next.a * x;
        let c = next.a * y * next.a.transpose() + next.c;
        // J₁₂ = A₁ᵀ (I + J₂ C₁)⁻¹ J₂ A₁ + J₁ = A₁ᵀ J₂ (I + C₁ J₂)⁻¹ A₁ + J₁.
        let j = self.a.transpose() * j2 * x + self.j;
        Element {
            a,
            c: (c + c.transpose()) * 0.5,
            j: (j + j.transpose()) * 0.5,
            ops: self.ops + next.ops,
        }
    }
}

/// The largest `α` with `P − αU` not negative definite: the largest
/// eigenvalue of `U⁻¹P` (both symmetric positive definite), on the
/// diagonally scaled matrices (the error state mixes radians of latitude
/// with metres per second). Infinite when `U` is not positive definite.
///
/// Generic in the state count (the filter's is 21); computed on
/// dynamically sized copies, which need no dimension bounds.
pub fn generalized_lambda_max<const N: usize>(
    p: &SMatrix<f64, N, N>,
    u: &SMatrix<f64, N, N>,
) -> f64 {
    let d: [f64; N] = std::array::from_fn(|i| {
        let x = u[(i, i)];
        if x > 0.0 {
            1.0 / x.sqrt()
        } else {
            1.0
        }
    });
    let us = nalgebra::DMatrix::from_fn(N, N, |i, j| u[(i, j)] * d[i] * d[j]);
    let ps = nalgebra::DMatrix::from_fn(N, N, |i, j| p[(i, j)] * d[i] * d[j]);
    let Some(c) = nalgebra::Cholesky::new(us) else {
        return f64::INFINITY;
    };
    let l = c.l();
    // M = L⁻¹ P L⁻ᵀ, symmetric with the eigenvalues of U⁻¹P.
    let Some(x) = l.solve_lower_triangular(&ps) else {
        return f64::INFINITY;
    };
    let Some(m) = l.solve_lower_triangular(&x.transpose()) else {
        return f64::INFINITY;
    };
    let m = (&m + m.transpose()) * 0.5;
    let e = nalgebra::SymmetricEigen::new(m).eigenvalues;
    if e.iter().any(|x| x.is_nan()) {
        return f64::INFINITY;
    }
    let top = e.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if top.is_finite() {
        top
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::Element;
    use nalgebra::{SMatrix, SVector};

    type M5 = SMatrix<f64, 5, 5>;

    /// A deterministic SPD matrix.
    fn spd(seed: f64) -> M5 {
        let a = M5::from_fn(|i, j| ((i * 5 + j) as f64 * 0.37 + seed).sin());
        a * a.transpose() + M5::identity() * 0.3
    }

    /// Propagations and updates applied one by one, as the filter does.
    struct Ops {
        phi: Vec<Vec<(u8, u8, f64)>>,
        h: Vec<SMatrix<f64, 2, 5>>,
    }

    fn ops(seed: f64) -> Ops {
        let phi = (0..3)
            .map(|n| {
                (0..7)
                    .map(|k| {
                        let x = ((k + 3 * n) as f64 * 1.7 + seed).cos() * 0.2;
                        (((k * 3 + n) % 5) as u8, ((k * 2 + 1) % 5) as u8, x)
                    })
                    .collect()
            })
            .collect();
        let h = (0..3)
            .map(|n| SMatrix::<f64, 2, 5>::from_fn(|i, j| ((i + j + n) as f64 + seed).sin()))
            .collect();
        Ops { phi, h }
    }

    fn direct(p: &M5, o: &Ops, q: &SVector<f64, 5>, r: &SMatrix<f64, 2, 2>) -> M5 {
        let mut p = *p;
        for (phi, h) in o.phi.iter().zip(&o.h) {
            let mut f = M5::identity();
            for &(i, k, x) in phi {
                f[(i as usize, k as usize)] += x;
            }
            p = f * p * f.transpose() + M5::from_diagonal(q) * 0.1;
            let s = h * p * h.transpose() + r;
            let k = p * h.transpose() * s.try_inverse().expect("S");
            p -= k * h * p;
        }
        p
    }

    fn element(o: &Ops, q: &SVector<f64, 5>, r: &SMatrix<f64, 2, 2>) -> Element<5> {
        let mut e = Element::identity();
        for (phi, h) in o.phi.iter().zip(&o.h) {
            e.propagate(phi, q, 0.1);
            e.update(h, r);
        }
        e
    }

    /// The element of propagations and updates maps a prior to the very
    /// covariance the ops give one by one (to round-off: 1e-10 of the
    /// entries, O(1) here), composes associatively with another stretch's
    /// (`then`), and stays under its PSD upper bound `A P Aᵀ + C`.
    #[test]
    fn element_reproduces_the_ops_and_composes() {
        let q = SVector::<f64, 5>::from_fn(|i, _| 0.1 + 0.05 * i as f64);
        let r = SMatrix::<f64, 2, 2>::new(0.5, 0.1, 0.1, 0.4);
        let (o1, o2) = (ops(0.3), ops(1.1));
        let (e1, e2) = (element(&o1, &q, &r), element(&o2, &q, &r));
        for seed in [0.0, 2.0, 5.0] {
            let p = spd(seed);
            let want1 = direct(&p, &o1, &q, &r);
            assert!((e1.apply(&p) - want1).abs().max() < 1e-10);
            let want12 = direct(&want1, &o2, &q, &r);
            assert!((e2.apply(&e1.apply(&p)) - want12).abs().max() < 1e-10);
            assert!((e1.then(&e2).apply(&p) - want12).abs().max() < 1e-10);
            // A P Aᵀ + C − f(P) is positive semi-definite.
            let gap = e1.a * p * e1.a.transpose() + e1.c - want1;
            let low = gap.symmetric_eigen().eigenvalues.min();
            assert!(low > -1e-10, "{low}");
        }
    }
}
