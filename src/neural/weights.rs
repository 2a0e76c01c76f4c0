//! A one-hidden-layer sigmoid MLP in f64 (nalgebra): y = W2 s(W1 x + b1) + b2, s the logistic
//! sigmoid (thesis 3.2). Prediction and the Levenberg-Marquardt phase run here; burn trains the
//! first phase and keeps the saved record (see `net`).

use nalgebra::{DMatrix, DVector};

/// Weights of the network.
#[derive(Debug, PartialEq)]
pub struct Weights {
    /// hidden x inputs.
    pub w1: DMatrix<f64>,
    /// hidden.
    pub b1: DVector<f64>,
    /// outputs x hidden.
    pub w2: DMatrix<f64>,
    /// outputs.
    pub b2: DVector<f64>,
}

impl Clone for Weights {
    fn clone(&self) -> Self {
        Weights {
            w1: self.w1.clone(),
            b1: self.b1.clone(),
            w2: self.w2.clone(),
            b2: self.b2.clone(),
        }
    }

    /// Copies `source` into the matrices already held where the shapes agree (the best
    /// weights of a training, rewritten at every improvement, without allocating).
    fn clone_from(&mut self, source: &Self) {
        let same = self.w1.shape() == source.w1.shape()
            && self.b1.len() == source.b1.len()
            && self.w2.shape() == source.w2.shape()
            && self.b2.len() == source.b2.len();
        if same {
            self.w1.copy_from(&source.w1);
            self.b1.copy_from(&source.b1);
            self.w2.copy_from(&source.w2);
            self.b2.copy_from(&source.b2);
        } else {
            *self = source.clone();
        }
    }
}

impl Weights {
    /// Number of inputs (columns of W1).
    pub fn inputs(&self) -> usize {
        self.w1.ncols()
    }

    /// Number of hidden units (rows of W1).
    pub fn hidden(&self) -> usize {
        self.w1.nrows()
    }

    /// Number of outputs (rows of W2).
    pub fn outputs(&self) -> usize {
        self.w2.nrows()
    }

    /// Number of weights and biases.
    pub fn len(&self) -> usize {
        let (h, i, o) = (self.hidden(), self.inputs(), self.outputs());
        h * i + h + o * h + o
    }

    /// Whether the network has no weights or biases at all.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// All weights in one vector: W1 (row-major), b1, W2 (row-major), b2.
    pub fn to_vector(&self) -> DVector<f64> {
        let mut v = DVector::zeros(self.len());
        self.write_vector(&mut v);
        v
    }

    /// [`Weights::to_vector`] into `v` (of [`Weights::len`] entries), without allocating: the
    /// one place that lays the weights out.
    pub fn write_vector(&self, v: &mut DVector<f64>) {
        debug_assert_eq!(v.len(), self.len(), "weight vector of another shape");
        let (h, i, o) = (self.hidden(), self.inputs(), self.outputs());
        let mut k = 0;
        for j in 0..h {
            for c in 0..i {
                v[k] = self.w1[(j, c)];
                k += 1;
            }
        }
        v.rows_mut(k, h).copy_from(&self.b1);
        k += h;
        for r in 0..o {
            for j in 0..h {
                v[k] = self.w2[(r, j)];
                k += 1;
            }
        }
        v.rows_mut(k, o).copy_from(&self.b2);
    }

    /// [`Weights::from_vector`] in place: these weights take the values of `v` (same
    /// shape), without allocating.
    pub fn read_vector(&mut self, v: &DVector<f64>) {
        debug_assert_eq!(v.len(), self.len(), "weight vector of another shape");
        let (h, i, o) = (self.hidden(), self.inputs(), self.outputs());
        let mut k = 0;
        for j in 0..h {
            for c in 0..i {
                self.w1[(j, c)] = v[k];
                k += 1;
            }
        }
        self.b1.copy_from(&v.rows(k, h));
        k += h;
        for r in 0..o {
            for j in 0..h {
                self.w2[(r, j)] = v[k];
                k += 1;
            }
        }
        self.b2.copy_from(&v.rows(k, o));
    }

    /// The inverse of [`Weights::to_vector`] for the same shape.
    pub fn from_vector(&self, v: &DVector<f64>) -> Weights {
        let mut w = self.clone();
        w.read_vector(v);
        w
    }

    /// Output for input `x`; `hidden` receives the hidden activations.
    pub fn forward_into(&self, x: &[f64], hidden: &mut [f64], y: &mut [f64]) {
        for (j, hj) in hidden.iter_mut().enumerate() {
            let mut z = self.b1[j];
            for (i, xi) in x.iter().enumerate() {
                z += self.w1[(j, i)] * xi;
            }
            *hj = super::logistic::logistic(z);
        }
        for (k, yk) in y.iter_mut().enumerate() {
            let mut s = self.b2[k];
            for (j, hj) in hidden.iter().enumerate() {
                s += self.w2[(k, j)] * hj;
            }
            *yk = s;
        }
    }

    /// Outputs at `x` into `y` and their derivatives by the inputs into `jac` (outputs x
    /// inputs): `dy_k/dx_i = sum_j W2[k,j] h_j (1 - h_j) W1[j,i]`. Does not allocate.
    pub fn input_jacobian_into(
        &self,
        x: &[f64],
        hidden: &mut [f64],
        y: &mut [f64],
        jac: &mut DMatrix<f64>,
    ) {
        self.forward_into(x, hidden, y);
        jac.fill(0.0);
        for (j, hj) in hidden.iter().enumerate() {
            let s = hj * (1.0 - hj);
            for k in 0..self.outputs() {
                let d = self.w2[(k, j)] * s;
                for i in 0..self.inputs() {
                    jac[(k, i)] += d * self.w1[(j, i)];
                }
            }
        }
    }

    /// Output for input `x` (allocates; for tests and one-off use).
    pub fn forward(&self, x: &[f64]) -> Vec<f64> {
        let mut h = vec![0.0; self.hidden()];
        let mut y = vec![0.0; self.outputs()];
        self.forward_into(x, &mut h, &mut y);
        y
    }

    /// Outputs at `x` into `y` and their Jacobian with respect to every weight (outputs x len,
    /// in the order of [`Weights::to_vector`]) into `jac` rows `row0..row0 + outputs`; one
    /// forward pass serves both, and nothing is allocated.
    ///
    /// `dy_k/dW2[k,j] = h_j`, `dy_k/db2[k] = 1`, `dy_k/dW1[j,i] = W2[k,j] h_j (1 - h_j) x_i`,
    /// `dy_k/db1[j] = W2[k,j] h_j (1 - h_j)`.
    pub fn jacobian_into(
        &self,
        x: &[f64],
        hidden: &mut [f64],
        y: &mut [f64],
        jac: &mut DMatrix<f64>,
        row0: usize,
    ) {
        let (h, i, o) = (self.hidden(), self.inputs(), self.outputs());
        self.forward_into(x, hidden, y);
        let (off_b1, off_w2, off_b2) = (h * i, h * i + h, h * i + h + o * h);
        for k in 0..o {
            let r = row0 + k;
            for c in 0..self.len() {
                jac[(r, c)] = 0.0;
            }
            for j in 0..h {
                let d = self.w2[(k, j)] * hidden[j] * (1.0 - hidden[j]);
                for (ii, xi) in x.iter().enumerate() {
                    jac[(r, j * i + ii)] = d * xi;
                }
                jac[(r, off_b1 + j)] = d;
                jac[(r, off_w2 + k * h + j)] = hidden[j];
            }
            jac[(r, off_b2 + k)] = 1.0;
        }
    }
}

/// Bound on every number a compensator stores: weights, normalisation offsets and scales (and
/// the inverse of a scale). Trained values stay far below; a finite 1e308 would overflow to
/// an infinite prediction in the first product.
pub const VALUE_BOUND: f64 = 1e9;

/// An affine normalisation of each feature, v_norm = (v - offset) / scale, fitted on training
/// data and stored with the network.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Affine {
    /// Subtracted from each raw feature (raw units).
    pub offset: Vec<f64>,
    /// Divides each centred feature (raw units per normalised unit).
    pub scale: Vec<f64>,
}

impl Affine {
    /// Mean 0 and standard deviation 1 over `rows` (of equal length); a constant feature
    /// keeps scale 1. A feature counts as constant where its deviation is at most
    /// 1 / [`VALUE_BOUND`] of its size (max(1, |mean|)): what is left at a billionth is
    /// rounding or a second-order trace (the gravity direction's z in a link that turns about
    /// an axis tilted by a few 1e-5 rad, as in a SCARA's), and a smaller scale could not be
    /// stored.
    pub fn standardise(rows: &[Vec<f64>]) -> Affine {
        let n = rows.first().map_or(0, |r| r.len());
        let count = rows.len().max(1) as f64;
        let offset: Vec<f64> = (0..n)
            .map(|k| rows.iter().map(|r| r[k]).sum::<f64>() / count)
            .collect();
        let scale = (0..n)
            .map(|k| {
                let var = rows.iter().map(|r| (r[k] - offset[k]).powi(2)).sum::<f64>() / count;
                let deviation = var.sqrt();
                if deviation > offset[k].abs().max(1.0) / VALUE_BOUND {
                    deviation
                } else {
                    1.0
                }
            })
            .collect();
        Affine { offset, scale }
    }

    /// Each scale raised to at least its `floor` (a feature that varies less is scaled as if
    /// it varied that much; see [`crate::neural::encoding::SCALE_FLOOR`]).
    pub fn floored(mut self, floor: &[f64]) -> Affine {
        for (s, f) in self.scale.iter_mut().zip(floor) {
            *s = s.max(*f);
        }
        self
    }

    /// Scale only (offset 0).
    pub fn scaling(scale: Vec<f64>) -> Affine {
        Affine {
            offset: vec![0.0; scale.len()],
            scale,
        }
    }

    /// Number of features.
    pub fn len(&self) -> usize {
        self.offset.len()
    }

    /// Whether there are no features.
    pub fn is_empty(&self) -> bool {
        self.offset.is_empty()
    }

    /// Raw to normalised.
    pub fn apply(&self, v: &[f64], out: &mut [f64]) {
        for k in 0..v.len() {
            out[k] = (v[k] - self.offset[k]) / self.scale[k];
        }
    }

    /// Normalised back to raw.
    pub fn invert(&self, v: &[f64], out: &mut [f64]) {
        for k in 0..v.len() {
            out[k] = v[k] * self.scale[k] + self.offset[k];
        }
    }

    /// True when every offset lies within +-[`VALUE_BOUND`] and every scale in
    /// [1 / [`VALUE_BOUND`], [`VALUE_BOUND`]].
    pub fn is_valid(&self) -> bool {
        self.offset.len() == self.scale.len()
            && self.offset.iter().all(|v| v.abs() <= VALUE_BOUND)
            && self
                .scale
                .iter()
                .all(|v| (1.0 / VALUE_BOUND..=VALUE_BOUND).contains(v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Weights {
        let f = |r, c, s: f64| DMatrix::from_fn(r, c, |i, j| ((i * 7 + j * 3) as f64 * s).sin());
        Weights {
            w1: f(4, 3, 0.37),
            b1: DVector::from_fn(4, |i, _| (i as f64 * 0.9).cos()),
            w2: f(2, 4, 0.53),
            b2: DVector::from_fn(2, |i, _| i as f64 * 0.1 - 0.2),
        }
    }

    #[test]
    fn clone_from_copies_in_place_and_takes_another_shape() {
        let source = sample();
        let mut kept = sample();
        kept.w1 *= 2.0;
        kept.b2[1] = 9.0;
        let at = (
            kept.w1.as_ptr(),
            kept.b1.as_ptr(),
            kept.w2.as_ptr(),
            kept.b2.as_ptr(),
        );
        kept.clone_from(&source);
        assert_eq!(kept, source);
        // The same storage: copied in place, not reallocated.
        let now = (
            kept.w1.as_ptr(),
            kept.b1.as_ptr(),
            kept.w2.as_ptr(),
            kept.b2.as_ptr(),
        );
        assert_eq!(at, now);
        let mut other = Weights {
            w1: DMatrix::zeros(2, 3),
            b1: DVector::zeros(2),
            w2: DMatrix::zeros(1, 2),
            b2: DVector::zeros(1),
        };
        other.clone_from(&source);
        assert_eq!(other, source);
    }

    #[test]
    fn in_place_vector_copies_match_the_allocating_ones() {
        let w = sample();
        let v = w.to_vector();
        // The layout, written out: W1 row by row, b1, W2 row by row, b2.
        let mut expected: Vec<f64> = Vec::new();
        for j in 0..w.hidden() {
            expected.extend(w.w1.row(j).iter());
        }
        expected.extend(w.b1.iter());
        for o in 0..w.outputs() {
            expected.extend(w.w2.row(o).iter());
        }
        expected.extend(w.b2.iter());
        assert_eq!(v.as_slice(), expected.as_slice());
        let mut written = DVector::from_element(w.len(), f64::NAN);
        w.write_vector(&mut written);
        assert_eq!(written, v);
        // Another network of the same shape takes w's values.
        let mut other = w.from_vector(&v.map(|x| -2.0 * x + 1.0));
        assert_ne!(other, w);
        other.read_vector(&v);
        assert_eq!(other, w);
        assert_eq!(other, w.from_vector(&v));
    }

    #[test]
    fn weight_jacobian_matches_central_differences() {
        let w = sample();
        let x = [0.3, -0.7, 0.55];
        let n = w.len();
        let mut jac = DMatrix::zeros(2, n);
        let mut h = vec![0.0; w.hidden()];
        let mut y = vec![0.0; 2];
        w.jacobian_into(&x, &mut h, &mut y, &mut jac, 0);
        assert_eq!(y, w.forward(&x));
        let v = w.to_vector();
        for c in 0..n {
            let e = 1e-6;
            let mut vp = v.clone();
            vp[c] += e;
            let mut vm = v.clone();
            vm[c] -= e;
            let (yp, ym) = (
                w.from_vector(&vp).forward(&x),
                w.from_vector(&vm).forward(&x),
            );
            for k in 0..2 {
                let fd = (yp[k] - ym[k]) / (2.0 * e);
                assert!(
                    (fd - jac[(k, c)]).abs() < 1e-8 * (1.0 + fd.abs()),
                    "weight {c}, output {k}: {fd} vs {}",
                    jac[(k, c)]
                );
            }
        }
    }

    #[test]
    fn input_jacobian_matches_central_differences() {
        let w = sample();
        let x = [0.3, -0.7, 0.55];
        let mut jac = DMatrix::zeros(2, 3);
        let mut h = vec![0.0; w.hidden()];
        let mut y = vec![0.0; 2];
        w.input_jacobian_into(&x, &mut h, &mut y, &mut jac);
        assert_eq!(y, w.forward(&x));
        for i in 0..3 {
            let e = 1e-6;
            let (mut xp, mut xm) = (x, x);
            xp[i] += e;
            xm[i] -= e;
            let (yp, ym) = (w.forward(&xp), w.forward(&xm));
            for k in 0..2 {
                let fd = (yp[k] - ym[k]) / (2.0 * e);
                assert!(
                    (fd - jac[(k, i)]).abs() < 1e-8 * (1.0 + fd.abs()) && jac[(k, i)] != 0.0,
                    "input {i}, output {k}: {fd} vs {}",
                    jac[(k, i)]
                );
            }
        }
    }

    #[test]
    fn vector_round_trip_and_normalisation() {
        let w = sample();
        assert_eq!(w.from_vector(&w.to_vector()), w);
        let m = Affine::standardise(&[vec![0.0, 5.0], vec![10.0, 5.0]]);
        assert_eq!(
            (m.offset.clone(), m.scale.clone()),
            (vec![5.0, 5.0], vec![5.0, 1.0])
        );
        let mut out = [0.0; 2];
        m.apply(&[10.0, 5.0], &mut out);
        assert_eq!(out, [1.0, 0.0]);
        let mut back = [0.0; 2];
        m.invert(&out, &mut back);
        assert_eq!(back, [10.0, 5.0]);
        assert!(m.is_valid() && !Affine::scaling(vec![0.0]).is_valid());
    }

    /// A feature whose spread is a billionth of its size or less is constant (scale 1): the
    /// normalisation of a SCARA's gravity features, where a z varied by 4e-10 about 1, can
    /// be stored; spreads above it are kept whatever the feature's size.
    #[test]
    fn spreads_at_a_billionth_of_the_size_are_constant() {
        let rows: Vec<Vec<f64>> = (0..8)
            .map(|i| {
                let s = if i % 2 == 0 { 1.0 } else { -1.0 };
                vec![
                    1.0 + s * 4e-10,
                    500.0 + s * 4e-7,
                    s * 4e-10,
                    1.0 + s * 2e-9,
                    s * 1e-6,
                ]
            })
            .collect();
        let m = Affine::standardise(&rows);
        assert_eq!(&m.scale[..3], &[1.0, 1.0, 1.0]);
        assert!((m.scale[3] / 2e-9 - 1.0).abs() < 1e-6, "{:?}", m.scale);
        assert!((m.scale[4] / 1e-6 - 1.0).abs() < 1e-9, "{:?}", m.scale);
        assert!(m.is_valid());
    }
}
