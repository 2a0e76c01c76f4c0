//! Training samples of a network: normalised inputs, unit-scale targets, optional per-sample
//! maps of the outputs, and the penalised mean squared residual with its analytic gradient.
//!
//! The residual of sample k is r_k = b_k - A_k y(x_k) (A_k = I without maps): the thesis's
//! pose network has A_k = I, the joint-space network A_k = W J(q_k), the weighted joint
//! Jacobian of the model.
//!
//! Objective (an L2 weight penalty as MATLAB's msereg / a Gaussian prior on the weights):
//! F(w) = (sum_k |r_k|^2 + lambda |W|^2) / M, M the number of residual components and |W|^2
//! the squared weights of both layers (biases are not penalised: the output bias carries
//! constant errors). lambda weighs one squared weight against one squared unit-scale
//! residual, so its effect fades as the data grow, as a prior's should.

use super::weights::Weights;
use nalgebra::{DMatrix, DVector};

/// Training samples: normalised inputs `x[k]`, targets `b[k]`, optional maps `maps[k]`
/// (rows of b x network outputs) and a group per sample (rows of one repeated configuration
/// share a group and are never split between training and held-out parts).
#[derive(Debug, Clone, Default)]
pub struct Samples {
    /// Normalised network inputs, one vector per sample.
    pub x: Vec<Vec<f64>>,
    /// Unit-scale targets, one vector per sample.
    pub b: Vec<Vec<f64>>,
    /// Per-sample maps A_k from network outputs to target rows (rows of b x outputs); None
    /// means A_k = I.
    pub maps: Option<Vec<DMatrix<f64>>>,
    /// Group of each sample; empty: every sample its own group.
    pub groups: Vec<usize>,
    /// Each input's resolution (normalised units, at most 1): the least change of it the
    /// encoding tells apart, its scale floor ([`Encoding::scale_floors`], about a 3 deg turn)
    /// over its scale. The RBF network's widths are held at or above it
    /// ([`crate::neural::rbf::WIDTH_FLOOR_SD`]). Empty: no bound.
    ///
    /// [`Encoding::scale_floors`]: crate::neural::encoding::Encoding::scale_floors
    pub resolution: Vec<f64>,
}

impl Samples {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Rows of each target (all equal, checked by training).
    pub fn rows(&self) -> usize {
        self.b.first().map_or(0, |b| b.len())
    }

    /// The group of sample `k`.
    pub fn group(&self, k: usize) -> usize {
        self.groups.get(k).copied().unwrap_or(k)
    }

    /// The samples at `idx`.
    pub fn pick(&self, idx: &[usize]) -> Samples {
        Samples {
            x: idx.iter().map(|&i| self.x[i].clone()).collect(),
            b: idx.iter().map(|&i| self.b[i].clone()).collect(),
            maps: self
                .maps
                .as_ref()
                .map(|m| idx.iter().map(|&i| m[i].clone()).collect()),
            groups: idx.iter().map(|&i| self.group(i)).collect(),
            resolution: self.resolution.clone(),
        }
    }

    /// Writes r_k = b_k - A_k y into `r`.
    pub fn residual(&self, k: usize, y: &[f64], r: &mut [f64]) {
        match &self.maps {
            None => {
                for (c, rc) in r.iter_mut().enumerate() {
                    *rc = self.b[k][c] - y[c];
                }
            }
            Some(m) => {
                let a = &m[k];
                for (row, rr) in r.iter_mut().enumerate() {
                    let mut s = self.b[k][row];
                    for (c, yc) in y.iter().enumerate() {
                        s -= a[(row, c)] * yc;
                    }
                    *rr = s;
                }
            }
        }
    }

    /// Number of residual components, M.
    pub fn components(&self) -> usize {
        self.len() * self.rows()
    }

    /// Mean squared residual (no penalty); 0 for no samples.
    pub fn mse(&self, w: &Weights) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let mut ws = SamplesWorkspace::new(w, self.rows());
        let mut sum = 0.0;
        for k in 0..self.len() {
            w.forward_into(&self.x[k], &mut ws.h, &mut ws.y);
            self.residual(k, &ws.y, &mut ws.r);
            sum += ws.r.iter().map(|v| v * v).sum::<f64>();
        }
        sum / self.components() as f64
    }
}

/// Sum of the squared weights of both layers (biases excluded).
pub fn weight_norm2(w: &Weights) -> f64 {
    w.w1.norm_squared() + w.w2.norm_squared()
}

/// 1 for the entries of [`Weights::to_vector`] that the penalty acts on (weights), 0 for
/// biases.
pub fn penalty_mask(w: &Weights) -> DVector<f64> {
    let (h, i, o) = (w.hidden(), w.inputs(), w.outputs());
    let mut m = DVector::zeros(w.len());
    m.rows_mut(0, h * i).fill(1.0);
    m.rows_mut(h * i + h, o * h).fill(1.0);
    m
}

/// Buffers of one forward and backward pass.
struct SamplesWorkspace {
    h: Vec<f64>,
    y: Vec<f64>,
    r: Vec<f64>,
    gy: Vec<f64>,
    gz: Vec<f64>,
}

impl SamplesWorkspace {
    fn new(w: &Weights, rows: usize) -> Self {
        SamplesWorkspace {
            h: vec![0.0; w.hidden()],
            y: vec![0.0; w.outputs()],
            r: vec![0.0; rows],
            gy: vec![0.0; w.outputs()],
            gz: vec![0.0; w.hidden()],
        }
    }
}

/// The penalised objective F (module doc) of `w` on `s` and its gradient by every entry of
/// [`Weights::to_vector`], written into `grad` (backpropagation; one pass per sample).
pub fn objective(s: &Samples, w: &Weights, lambda: f64, grad: &mut DVector<f64>) -> f64 {
    let (nh, ni, no) = (w.hidden(), w.inputs(), w.outputs());
    let (off_b1, off_w2, off_b2) = (nh * ni, nh * ni + nh, nh * ni + nh + no * nh);
    let m = s.components().max(1) as f64;
    let mut ws = SamplesWorkspace::new(w, s.rows());
    grad.fill(0.0);
    let mut sum = 0.0;
    for k in 0..s.len() {
        let x = &s.x[k];
        w.forward_into(x, &mut ws.h, &mut ws.y);
        s.residual(k, &ws.y, &mut ws.r);
        sum += ws.r.iter().map(|v| v * v).sum::<f64>();
        // dF/dy = -(2/M) A^T r.
        match &s.maps {
            None => {
                for (g, r) in ws.gy.iter_mut().zip(&ws.r) {
                    *g = -2.0 / m * r;
                }
            }
            Some(a) => {
                let a = &a[k];
                for (c, g) in ws.gy.iter_mut().enumerate() {
                    let mut t = 0.0;
                    for (row, r) in ws.r.iter().enumerate() {
                        t += a[(row, c)] * r;
                    }
                    *g = -2.0 / m * t;
                }
            }
        }
        for (j, gz) in ws.gz.iter_mut().enumerate() {
            let mut t = 0.0;
            for (o, gy) in ws.gy.iter().enumerate() {
                t += w.w2[(o, j)] * gy;
                grad[off_w2 + o * nh + j] += gy * ws.h[j];
            }
            *gz = t * ws.h[j] * (1.0 - ws.h[j]);
            grad[off_b1 + j] += *gz;
            for (i, xi) in x.iter().enumerate() {
                grad[j * ni + i] += *gz * xi;
            }
        }
        for (o, gy) in ws.gy.iter().enumerate() {
            grad[off_b2 + o] += gy;
        }
    }
    if lambda > 0.0 {
        let v = w.to_vector();
        let mask = penalty_mask(w);
        for c in 0..v.len() {
            grad[c] += 2.0 * lambda / m * mask[c] * v[c];
        }
    }
    (sum + lambda * weight_norm2(w)) / m
}

/// A small network (3 inputs, 4 hidden, 2 outputs, every weight nonzero) and `count` samples
/// for it, with maps to 3 residual rows where `with_maps`: the fixture of the gradient tests.
#[cfg(test)]
pub(crate) fn test_fixture(with_maps: bool, count: usize) -> (Weights, Samples) {
    let w = Weights {
        w1: DMatrix::from_fn(4, 3, |i, j| ((i * 7 + j * 3) as f64 * 0.37).sin()),
        b1: DVector::from_fn(4, |i, _| (i as f64 * 0.9).cos()),
        w2: DMatrix::from_fn(2, 4, |i, j| ((i * 5 + j) as f64 * 0.53).sin()),
        b2: DVector::from_fn(2, |i, _| i as f64 * 0.1 - 0.2),
    };
    let mut s = Samples::default();
    let mut maps = Vec::new();
    for k in 0..count {
        let t = k as f64;
        s.x.push(vec![(t * 0.7).sin(), (t * 1.3).cos(), t * 0.1 - 0.2]);
        if with_maps {
            s.b.push(vec![t * 0.2, -0.3, 0.5 - t * 0.1]);
            maps.push(DMatrix::from_fn(3, 2, |i, j| {
                ((k + i * 2 + j) as f64).cos()
            }));
        } else {
            s.b.push(vec![t * 0.2, -0.3]);
        }
    }
    s.maps = with_maps.then_some(maps);
    (w, s)
}
