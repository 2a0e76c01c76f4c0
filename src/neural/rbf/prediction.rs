//! Prediction of an RBF network ([`super`]): its outputs y(x) at one input and their
//! Jacobian dy/dx (normalised inputs, unit-scale outputs).

use super::{Kernel, Rbf};
use nalgebra::DMatrix;

/// Units whose responses prediction takes at once (a buffer on the stack).
const CHUNK: usize = 64;

/// The most one-output kernels whose sums [`Rbf::forward_into`] advances side by side (a
/// pose's six, with room); more go one after another.
const INTERLEAVED: usize = 8;

/// The weighted squared distance sum_d (x_d - c_d)^2 / l_d^2 of `x` from the unit at `c`,
/// with `inv` the kernel's 1 / l_d^2 (multiplications: per input and unit a division cost
/// four times as much, most of a prediction).
fn distance(x: &[f64], c: &[f64], inv: &[f64]) -> f64 {
    let mut s = 0.0;
    for ((xd, cd), i) in x.iter().zip(c).zip(inv) {
        let t = xd - cd;
        s += t * t * i;
    }
    s
}

/// [`distance`] of `x` from every unit of `centres`, into `q` (as long as `centres`), four
/// units at a time: four independent sums instead of one chain of additions each waiting
/// for the last (a prediction's cost, which the chain's latency bounded), every unit's sum in
/// the same order as [`distance`]'s, so the same bits.
fn distances(x: &[f64], centres: &[Vec<f64>], inv: &[f64], q: &mut [f64]) {
    let n = x.len().min(inv.len());
    let (x, inv) = (&x[..n], &inv[..n]);
    let mut groups = centres.chunks_exact(4);
    let mut outs = q.chunks_exact_mut(4);
    for (g, out) in (&mut groups).zip(&mut outs) {
        if g.iter().any(|c| c.len() < n) {
            out.iter_mut()
                .zip(g)
                .for_each(|(o, c)| *o = distance(x, c, inv));
            continue;
        }
        let (c0, c1, c2, c3) = (&g[0][..n], &g[1][..n], &g[2][..n], &g[3][..n]);
        let mut s = [0.0; 4];
        for d in 0..n {
            let (xd, i) = (x[d], inv[d]);
            let t = [xd - c0[d], xd - c1[d], xd - c2[d], xd - c3[d]];
            for (s, t) in s.iter_mut().zip(t) {
                *s += t * t * i;
            }
        }
        out.copy_from_slice(&s);
    }
    outs.into_remainder()
        .iter_mut()
        .zip(groups.remainder())
        .for_each(|(o, c)| *o = distance(x, c, inv));
}

impl Rbf {
    /// Each kernel with the outputs it serves and its 1 / l_d^2, which go into `inv` (scratch:
    /// no allocation once it has held them) kernel after kernel.
    fn kernels_with_inverses<'a>(
        &'a self,
        inv: &'a mut Vec<f64>,
    ) -> impl Iterator<Item = (&'a Kernel, std::ops::Range<usize>, &'a [f64])> {
        inv.clear();
        for k in &self.kernels {
            k.inverse_squares_into(inv);
        }
        let inv: &'a [f64] = inv;
        self.kernel_outputs().scan(0, move |at, (kernel, outs)| {
            let own = &inv[*at..*at + kernel.widths.len()];
            *at += kernel.widths.len();
            Some((kernel, outs, own))
        })
    }

    /// y(x) into `y`; `inv` is scratch (no allocation once it has been used).
    /// The units' distances go into a buffer of 64 at a time and their responses are
    /// taken over it ([`super::Covariance::responses_in_place`], vectorised); the outputs
    /// add the units in order. Where every kernel serves one output, as in networks fitted
    /// now, and there are at most eight of them (`INTERLEAVED`), the kernels take each block of
    /// units in turn and their sums advance side by side: each output's sum is one chain of
    /// additions, which bounded a prediction's speed while the outputs ran one after another
    /// (the same additions in the same order, so the same bits).
    pub fn forward_into(&self, x: &[f64], y: &mut [f64], inv: &mut Vec<f64>) {
        let kernels = self.kernels.len();
        if kernels > INTERLEAVED
            || kernels != y.len()
            || self.kernels.iter().any(|k| k.outputs != 1)
        {
            y.fill(0.0);
            self.forward_kernel_by_kernel(x, y, inv);
            return;
        }
        inv.clear();
        for k in &self.kernels {
            k.inverse_squares_into(inv);
        }
        let mut buffers = [[0.0; CHUNK]; INTERLEAVED];
        let mut sums = [0.0; INTERLEAVED];
        let sums = &mut sums[..kernels];
        for (centres, weights) in self.centres.chunks(CHUNK).zip(self.weights.chunks(CHUNK)) {
            let mut at = 0;
            for (kernel, q) in self.kernels.iter().zip(&mut buffers) {
                let own = &inv[at..at + kernel.widths.len()];
                at += kernel.widths.len();
                let q = &mut q[..centres.len()];
                distances(x, centres, own, q);
                kernel.covariance.responses_in_place(q, 1.0);
            }
            // Rows of weights as long as the kernels and no more than the block's units (a
            // valid network's: `is_valid`), or a panic as before.
            for (u, w) in weights.iter().take(centres.len()).enumerate() {
                for ((s, q), wo) in sums.iter_mut().zip(&buffers).zip(&w[..kernels]) {
                    *s += wo * q[u];
                }
            }
        }
        y.copy_from_slice(sums);
    }

    /// [`Rbf::forward_into`] one kernel after another (any kernel's output count), added
    /// into `y`.
    fn forward_kernel_by_kernel(&self, x: &[f64], y: &mut [f64], inv: &mut Vec<f64>) {
        let mut buffer = [0.0; CHUNK];
        for (kernel, outs, own) in self.kernels_with_inverses(inv) {
            for (centres, weights) in self.centres.chunks(CHUNK).zip(self.weights.chunks(CHUNK)) {
                let q = &mut buffer[..centres.len()];
                distances(x, centres, own, q);
                kernel.covariance.responses_in_place(q, 1.0);
                for (k, w) in q.iter().zip(weights) {
                    y[outs.clone()]
                        .iter_mut()
                        .zip(&w[outs.clone()])
                        .for_each(|(yo, wo)| *yo += wo * k);
                }
            }
        }
    }

    /// y(x) into `y` and dy/dx (outputs x inputs) into `dy`: dy_o/dx_d = -sum_i w_io g_io
    /// (x_d - c_id) / l_od^2, g = -2 dk/dq
    /// ([`super::Covariance::response_and_width_factor`]; the response itself for the
    /// squared exponential); `inv` is scratch as in [`Rbf::forward_into`]. One unit and one
    /// kernel at a time (compensated targets' solves; not the training's hot path).
    pub fn input_jacobian_into(
        &self,
        x: &[f64],
        y: &mut [f64],
        dy: &mut DMatrix<f64>,
        inv: &mut Vec<f64>,
    ) {
        y.fill(0.0);
        dy.fill(0.0);
        for (kernel, outs, own) in self.kernels_with_inverses(inv) {
            for (c, w) in self.centres.iter().zip(&self.weights) {
                let (k, g) = kernel
                    .covariance
                    .response_and_width_factor(distance(x, c, own));
                if k == 0.0 {
                    continue;
                }
                for o in outs.clone() {
                    y[o] += w[o] * k;
                    let wg = w[o] * g;
                    for (d, i) in own.iter().enumerate() {
                        dy[(o, d)] -= wg * (x[d] - c[d]) * i;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::data;
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// The four-at-a-time distances are [`distance`]'s bits for any count of units (groups
    /// of four and a remainder), any count of inputs, a unit shorter than the inputs, and
    /// inputs, widths and units of different lengths (the shortest counts, as in a zip).
    #[test]
    fn distances_four_at_a_time_are_one_at_a_time_bits() {
        use rand::Rng;
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let mut v = |scale: f64| rng.random_range(-1.0..1.0) * scale;
        for inputs in [0usize, 1, 3, 12, 30] {
            for units in [0, 1, 4, 5, 11, 64] {
                let x: Vec<f64> = (0..inputs)
                    .map(|d| v(10f64.powi(d as i32 % 7 - 3)))
                    .collect();
                let inv: Vec<f64> = (0..inputs).map(|_| v(1e3).abs()).collect();
                let mut centres: Vec<Vec<f64>> = (0..units)
                    .map(|_| {
                        (0..inputs)
                            .map(|d| v(10f64.powi(d as i32 % 5 - 2)))
                            .collect()
                    })
                    .collect();
                if units > 5 && inputs > 0 {
                    centres[5].truncate(inputs - 1);
                }
                // As given; one width short; one input short (centres one longer).
                for (x, inv) in [
                    (&x[..], &inv[..]),
                    (&x[..], &inv[..inputs.saturating_sub(1)]),
                    (&x[..inputs.saturating_sub(1)], &inv[..]),
                ] {
                    let mut q = vec![f64::NAN; units];
                    distances(x, &centres, inv, &mut q);
                    for (u, c) in centres.iter().enumerate() {
                        assert_eq!(
                            q[u].to_bits(),
                            distance(x, c, inv).to_bits(),
                            "{inputs} inputs ({} x, {} widths), {units} units, unit {u}",
                            x.len(),
                            inv.len()
                        );
                    }
                }
            }
        }
    }

    /// Prediction with the kernels side by side gives the bits of one kernel after another,
    /// on a fitted network (two one-output kernels, 150 units: two blocks of 64 and a
    /// remainder) and on the same network with six outputs. Past [`INTERLEAVED`] kernels and
    /// with a kernel of two outputs `forward_into` runs the kernel-by-kernel path itself, so
    /// those two cases check only that it is taken (the side-by-side path would mishandle
    /// them).
    #[test]
    fn kernels_side_by_side_give_the_bits_of_one_after_another() {
        let (s, _) = data(150);
        let (two, _) = Rbf::fit(&s, None, 1).unwrap();
        let widen = |outputs: usize| {
            let mut r = two.clone();
            r.kernels = (0..outputs)
                .map(|o| {
                    let mut k = two.kernels[o % 2].clone();
                    k.widths.iter_mut().for_each(|l| *l *= 1.0 + 0.1 * o as f64);
                    k
                })
                .collect();
            r.weights = two
                .weights
                .iter()
                .map(|w| {
                    (0..outputs)
                        .map(|o| w[o % 2] * (1.0 - 0.05 * o as f64))
                        .collect()
                })
                .collect();
            r
        };
        let mut shared = two.clone();
        shared.kernels.truncate(1);
        shared.kernels[0].outputs = 2;
        let mut inv = Vec::new();
        for rbf in [two.clone(), widen(6), widen(INTERLEAVED + 1), shared] {
            let outputs = rbf.weights[0].len();
            for x in [[0.3, -1.2, 0.7], [1.4, 0.0, -1.5], [9.0, 9.0, 9.0]] {
                let (mut y, mut reference) = (vec![f64::NAN; outputs], vec![0.0; outputs]);
                rbf.forward_into(&x, &mut y, &mut inv);
                rbf.forward_kernel_by_kernel(&x, &mut reference, &mut inv);
                let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&y), bits(&reference), "{outputs} outputs at {x:?}");
                assert!(y.iter().all(|v| v.is_finite()));
            }
        }
    }
}
