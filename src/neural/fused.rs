//! L-BFGS's vector passes fused, with the bits of the separate operations
//! ([`super::vectors`]: nalgebra's order). A dot product in nalgebra's order is a chain of
//! dependent additions (eight partial sums over blocks of eight), which leaves the processor
//! most of its loads, products and stores free: the update of the search direction that
//! precedes each dot product of the two-loop recursion runs in its shadow instead of in a
//! pass of its own, and the correction pair's differences and its three dot products share
//! one pass. Four values at a time in AVX2 registers (`pulp`'s V3) where the processor has
//! them; elsewhere the separate operations.

use super::vectors::dot_in;
use nalgebra::DVector;

/// What follows the update d + a x of [`update_dot`], element by element.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Then {
    /// Nothing.
    Keep,
    /// Times the factor (the bits of nalgebra's `d *= factor`).
    Scale(f64),
    /// Negated (nalgebra's `d.neg_mut()`).
    Negate,
}

impl Then {
    #[inline(always)]
    fn apply(self, v: f64) -> f64 {
        match self {
            Then::Keep => v,
            Then::Scale(f) => v * f,
            Then::Negate => -v,
        }
    }
}

/// d <- then(d + a x) element by element (the bits of nalgebra's `d.axpy(a, x, 1.0)`, then
/// `d *= factor` or `d.neg_mut()`); returns s . d of the new d in nalgebra's order (the bits
/// of [`super::vectors::dot`]).
pub fn update_dot(d: &mut [f64], a: f64, x: &[f64], then: Then, s: &[f64]) -> f64 {
    assert!(
        x.len() == d.len() && s.len() == d.len(),
        "update_dot: slices of unequal lengths"
    );
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = pulp::x86::V3::try_new() {
        return simd.vectorize(UpdateDotV3 {
            simd,
            d,
            a,
            x,
            then,
            s,
        });
    }
    for (d, x) in d.iter_mut().zip(x) {
        *d = then.apply(*d + a * x);
    }
    dot_in(s, d)
}

/// out <- x + a d element by element (the bits of `out.copy_from(x)` then nalgebra's
/// `out.axpy(a, d, 1.0)`): the line search's trial point.
pub fn step_to(out: &mut [f64], x: &[f64], a: f64, d: &[f64]) {
    assert!(
        x.len() == out.len() && d.len() == out.len(),
        "step_to: slices of unequal lengths"
    );
    crate::neural::wide::dispatch(
        #[inline(always)]
        || {
            for ((o, x), d) in out.iter_mut().zip(x).zip(d) {
                *o = x + a * d;
            }
        },
    );
}

/// s <- x_new - x and y <- g_new - g element by element; returns (s . s, y . y, s . y) in
/// nalgebra's order (the bits of [`super::vectors::dot`] of the new s and y).
pub fn differences(
    s: &mut DVector<f64>,
    x_new: &DVector<f64>,
    x: &DVector<f64>,
    y: &mut DVector<f64>,
    g_new: &DVector<f64>,
    g: &DVector<f64>,
) -> (f64, f64, f64) {
    let n = s.len();
    assert!(
        [x_new.len(), x.len(), y.len(), g_new.len(), g.len()]
            .iter()
            .all(|&l| l == n),
        "differences: vectors of unequal lengths"
    );
    let (s, y) = (s.as_mut_slice(), y.as_mut_slice());
    let (x_new, x, g_new, g) = (
        x_new.as_slice(),
        x.as_slice(),
        g_new.as_slice(),
        g.as_slice(),
    );
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = pulp::x86::V3::try_new() {
        return simd.vectorize(DifferencesV3 {
            simd,
            s,
            x_new,
            x,
            y,
            g_new,
            g,
        });
    }
    for k in 0..n {
        s[k] = x_new[k] - x[k];
        y[k] = g_new[k] - g[k];
    }
    (dot_in(s, s), dot_in(y, y), dot_in(s, y))
}

#[cfg(target_arch = "x86_64")]
use super::vectors::{finish, lanes, load4, store4};
#[cfg(target_arch = "x86_64")]
use pulp::{Simd as _, f64x4};

/// [`update_dot`] as the operation `vectorize` compiles with AVX2 (a method marked
/// `inline(always)`, as [`super::vectors`]' kernels: a closure is compiled apart from it).
#[cfg(target_arch = "x86_64")]
struct UpdateDotV3<'s> {
    simd: pulp::x86::V3,
    d: &'s mut [f64],
    a: f64,
    x: &'s [f64],
    then: Then,
    s: &'s [f64],
}

#[cfg(target_arch = "x86_64")]
impl pulp::NullaryFnOnce for UpdateDotV3<'_> {
    type Output = f64;

    #[inline(always)]
    fn call(self) -> f64 {
        let Self {
            simd,
            d,
            a,
            x,
            then,
            s,
        } = self;
        let av = simd.splat_f64s(a);
        let update = |dv: f64x4, xv: f64x4| -> f64x4 {
            let v = simd.add_f64s(dv, simd.mul_f64s(av, xv));
            match then {
                Then::Keep => v,
                Then::Scale(f) => simd.mul_f64s(v, simd.splat_f64s(f)),
                Then::Negate => f64x4(-v.0, -v.1, -v.2, -v.3),
            }
        };
        let (mut lo, mut hi) = (simd.splat_f64s(0.0), simd.splat_f64s(0.0));
        let body = d.len() / 8 * 8;
        for ((dc, xc), sc) in d[..body]
            .chunks_exact_mut(8)
            .zip(x.chunks_exact(8))
            .zip(s.chunks_exact(8))
        {
            let (vl, vh) = (
                update(load4(&dc[..4]), load4(&xc[..4])),
                update(load4(&dc[4..]), load4(&xc[4..])),
            );
            store4(&mut dc[..4], vl);
            store4(&mut dc[4..], vh);
            lo = simd.add_f64s(lo, simd.mul_f64s(load4(&sc[..4]), vl));
            hi = simd.add_f64s(hi, simd.mul_f64s(load4(&sc[4..]), vh));
        }
        for k in body..d.len() {
            d[k] = then.apply(d[k] + a * x[k]);
        }
        finish(s, d, lanes(lo), lanes(hi))
    }
}

/// [`differences`] as the operation `vectorize` compiles with AVX2.
#[cfg(target_arch = "x86_64")]
struct DifferencesV3<'s> {
    simd: pulp::x86::V3,
    s: &'s mut [f64],
    x_new: &'s [f64],
    x: &'s [f64],
    y: &'s mut [f64],
    g_new: &'s [f64],
    g: &'s [f64],
}

#[cfg(target_arch = "x86_64")]
impl pulp::NullaryFnOnce for DifferencesV3<'_> {
    type Output = (f64, f64, f64);

    #[inline(always)]
    fn call(self) -> (f64, f64, f64) {
        let Self {
            simd,
            s,
            x_new,
            x,
            y,
            g_new,
            g,
        } = self;
        let zero = simd.splat_f64s(0.0);
        // Partial sums (low and high halves of each block) of s.s, y.y and s.y.
        let mut acc = [zero; 6];
        let body = s.len() / 8 * 8;
        for k in (0..body).step_by(8) {
            for (h, at) in [k, k + 4].into_iter().enumerate() {
                let sv = simd.sub_f64s(load4(&x_new[at..]), load4(&x[at..]));
                let yv = simd.sub_f64s(load4(&g_new[at..]), load4(&g[at..]));
                store4(&mut s[at..], sv);
                store4(&mut y[at..], yv);
                acc[h] = simd.add_f64s(acc[h], simd.mul_f64s(sv, sv));
                acc[2 + h] = simd.add_f64s(acc[2 + h], simd.mul_f64s(yv, yv));
                acc[4 + h] = simd.add_f64s(acc[4 + h], simd.mul_f64s(sv, yv));
            }
        }
        for k in body..s.len() {
            s[k] = x_new[k] - x[k];
            y[k] = g_new[k] - g[k];
        }
        (
            finish(s, s, lanes(acc[0]), lanes(acc[1])),
            finish(y, y, lanes(acc[2]), lanes(acc[3])),
            finish(s, y, lanes(acc[4]), lanes(acc[5])),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neural::vectors::{axpy, dot};

    /// [`crate::neural::vectors`]' test values (many magnitudes, both signs), every
    /// seventeenth a zero (whose sign a negation must keep).
    fn values(seed: u64) -> impl FnMut() -> f64 {
        let mut spread = crate::neural::vectors::tests::values(seed);
        let mut count = 0usize;
        move || {
            count += 1;
            if count.is_multiple_of(17) {
                0.0
            } else {
                spread()
            }
        }
    }

    fn bits(v: &DVector<f64>) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    const LENGTHS: [usize; 12] = [0, 1, 7, 8, 9, 15, 16, 17, 63, 992, 1190, 1999];

    #[test]
    fn update_dot_gives_the_separate_operations_bits() {
        let mut next = values(0x9e37_79b9_7f4a_7c15_u64);
        for n in LENGTHS {
            let mut v = || DVector::from_fn(n, |_, _| next());
            let (d0, x, s) = (v(), v(), v());
            let a = next();
            for then in [Then::Keep, Then::Scale(0.37), Then::Negate] {
                let mut separate = d0.clone();
                axpy(&mut separate, a, &x);
                match then {
                    Then::Keep => {}
                    Then::Scale(f) => separate *= f,
                    Then::Negate => separate.neg_mut(),
                }
                let want = dot(&s, &separate);
                let mut fused = d0.clone();
                let got = update_dot(fused.as_mut_slice(), a, x.as_slice(), then, s.as_slice());
                assert_eq!(bits(&fused), bits(&separate), "d, n = {n}, {then:?}");
                assert_eq!(got.to_bits(), want.to_bits(), "dot, n = {n}, {then:?}");
            }
        }
    }

    #[test]
    fn step_and_differences_give_the_separate_operations_bits() {
        let mut next = values(0x853c_49e6_748f_ea9b_u64);
        for n in LENGTHS {
            let mut v = || DVector::from_fn(n, |_, _| next());
            let (x, d, x_new, g, g_new) = (v(), v(), v(), v(), v());
            let a = next();
            let mut trial = DVector::from_element(n, f64::NAN);
            step_to(trial.as_mut_slice(), x.as_slice(), a, d.as_slice());
            let mut separate = x.clone();
            axpy(&mut separate, a, &d);
            assert_eq!(bits(&trial), bits(&separate), "step, n = {n}");

            let (mut s, mut y) = (DVector::from_element(n, f64::NAN), DVector::zeros(n));
            let (ss, yy, sy) = differences(&mut s, &x_new, &x, &mut y, &g_new, &g);
            let (s0, y0) = (&x_new - &x, &g_new - &g);
            assert_eq!(bits(&s), bits(&s0), "s, n = {n}");
            assert_eq!(bits(&y), bits(&y0), "y, n = {n}");
            assert_eq!(ss.to_bits(), s0.dot(&s0).to_bits(), "s.s, n = {n}");
            assert_eq!(yy.to_bits(), y0.dot(&y0).to_bits(), "y.y, n = {n}");
            assert_eq!(sy.to_bits(), s0.dot(&y0).to_bits(), "s.y, n = {n}");
        }
    }
}
