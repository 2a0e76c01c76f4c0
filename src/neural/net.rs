//! The network as a burn module (ndarray backend, f64): the first training phase runs through
//! burn's autodiff and SGD-momentum optimizer, and the saved record is burn's (burnpack bytes).
//! Weights move to and from [`Weights`] (nalgebra) for the Levenberg-Marquardt phase and for
//! fast prediction.

use super::samples::Samples;
use super::weights::Weights;
use crate::error::{Error, Result};
use burn::module::{Module, Param, ParamId};
use burn::nn::loss::{MseLoss, Reduction};
use burn::nn::{Linear, LinearConfig};
use burn::optim::momentum::MomentumConfig;
use burn::optim::{GradientsParams, SgdConfig};
use burn::tensor::{Device, FloatDType, Tensor, TensorData};
use nalgebra::{DMatrix, DVector};

/// One hidden layer of sigmoid units and a linear output layer (thesis Fig. 3.7).
#[derive(Module, Debug)]
pub struct Mlp {
    hidden: Linear,
    out: Linear,
}

impl Mlp {
    fn new(device: &Device, inputs: usize, hidden: usize, outputs: usize) -> Self {
        Mlp {
            hidden: LinearConfig::new(inputs, hidden).init(device),
            out: LinearConfig::new(hidden, outputs).init(device),
        }
    }

    /// burn's own `sigmoid` computes in f32 whatever the tensor's dtype; the logistic is
    /// written out here so that training runs in f64 like the LM phase and prediction.
    fn forward(&self, x: Tensor<2>) -> Tensor<2> {
        let z = self.hidden.forward(x);
        self.out.forward(z.neg().exp().add_scalar(1.0).recip())
    }
}

/// The CPU device in f64, with autodiff when `grad` is set. burn 0.22 deprecates its ndarray
/// backend (0.22 is the last line that has it: the dependency is pinned).
#[allow(deprecated)]
fn device(grad: bool) -> Result<Device> {
    let mut d = Device::ndarray();
    // Must precede any tensor on the device; a later call finds it configured already, so
    // check the outcome rather than the call.
    let _ = d.configure(FloatDType::F64);
    let probe: Tensor<1> = Tensor::from_data(TensorData::new(vec![0.0f64], [1]), &d);
    if probe.dtype() != burn::tensor::DType::F64 {
        return Err(Error::Invalid(format!(
            "the ndarray device runs in {:?}, not f64",
            probe.dtype()
        )));
    }
    Ok(if grad { d.autodiff() } else { d })
}

fn tensor2(v: Vec<f64>, rows: usize, cols: usize, device: &Device) -> Tensor<2> {
    Tensor::from_data(TensorData::new(v, [rows, cols]), device)
}

fn read2(t: Tensor<2>) -> Result<Vec<f64>> {
    t.into_data()
        .convert::<f64>()
        .try_into_vec::<f64>()
        .map_err(|e| Error::Invalid(format!("reading network weights: {e:?}")))
}

fn read1(t: Tensor<1>) -> Result<Vec<f64>> {
    t.into_data()
        .convert::<f64>()
        .try_into_vec::<f64>()
        .map_err(|e| Error::Invalid(format!("reading network biases: {e:?}")))
}

/// burn keeps `Linear` weights as [inputs, outputs] (y = x W + b).
fn linear_to(l: &Linear) -> Result<(DMatrix<f64>, DVector<f64>)> {
    let w = l.weight.val();
    let [din, dout] = w.dims();
    let data = read2(w)?;
    let m = DMatrix::from_row_slice(din, dout, &data).transpose();
    let b = match &l.bias {
        Some(b) => DVector::from_vec(read1(b.val())?),
        None => DVector::zeros(dout),
    };
    Ok((m, b))
}

fn linear_from(l: Linear, w: &DMatrix<f64>, b: &DVector<f64>, device: &Device) -> Linear {
    let (dout, din) = (w.nrows(), w.ncols());
    // burn's [inputs, outputs] layout, row-major: entry (i, j) is w[(j, i)].
    let data: Vec<f64> = (0..din)
        .flat_map(|i| (0..dout).map(move |j| w[(j, i)]))
        .collect();
    let bias: Vec<f64> = b.iter().copied().collect();
    let weight = l.weight.map(|old| {
        tensor2(data.clone(), din, dout, device).set_require_grad(old.is_require_grad())
    });
    let bias = l.bias.map(|p| {
        p.map(|old| {
            Tensor::from_data(TensorData::new(bias.clone(), [dout]), device)
                .set_require_grad(old.is_require_grad())
        })
    });
    Linear { weight, bias }
}

impl Mlp {
    /// The weights as nalgebra matrices.
    pub fn weights(&self) -> Result<Weights> {
        let (w1, b1) = linear_to(&self.hidden)?;
        let (w2, b2) = linear_to(&self.out)?;
        Ok(Weights { w1, b1, w2, b2 })
    }

    /// This module with the given weights written in.
    pub fn with_weights(self, w: &Weights, device: &Device) -> Self {
        Mlp {
            hidden: linear_from(self.hidden, &w.w1, &w.b1, device),
            out: linear_from(self.out, &w.w2, &w.b2, device),
        }
    }
}

/// The burn record (burnpack bytes) of a network with these weights. The parameters carry
/// fixed ids (1 to 4): burn draws a new id for every parameter it creates, and the same
/// weights would otherwise give other bytes on every save.
pub fn record_bytes(w: &Weights) -> Result<Vec<u8>> {
    let d = device(false)?;
    let m = Mlp::new(&d, w.inputs(), w.hidden(), w.outputs()).with_weights(w, &d);
    let fixed = |l: Linear, k: u64| Linear {
        weight: Param::initialized(ParamId::from(k), l.weight.val()),
        bias: l
            .bias
            .map(|b| Param::initialized(ParamId::from(k + 1), b.val())),
    };
    let m = Mlp {
        hidden: fixed(m.hidden, 1),
        out: fixed(m.out, 3),
    };
    let bytes = m
        .into_record()
        .into_bytes()
        .map_err(|e| Error::Invalid(format!("saving the network record: {e:?}")))?;
    Ok(bytes.to_vec())
}

/// Weights from a burn record made by [`record_bytes`] for this shape.
pub fn weights_from_record(
    bytes: &[u8],
    inputs: usize,
    hidden: usize,
    outputs: usize,
) -> Result<Weights> {
    let d = device(false)?;
    let record =
        burn::store::ModuleRecord::from_bytes(burn::tensor::Bytes::from_bytes_vec(bytes.to_vec()))
            .map_err(|e| {
                let why: String = format!("{e:?}").chars().take(200).collect();
                Error::Invalid(format!("the network record is corrupt: {why}"))
            })?;
    let m = Mlp::new(&d, inputs, hidden, outputs)
        .try_load_record(record)
        .map_err(|_| {
            Error::Invalid(format!(
                "the network record does not fit a {inputs}-{hidden}-{outputs} network (its \
                 tensors have other shapes)"
            ))
        })?;
    m.weights()
}

/// The learning rate of phase 1 (thesis 3.2).
pub const LEARNING_RATE: f64 = 0.01;
/// The largest step phase 1 takes along the penalty's own curvature (rate x 2 lambda / M):
/// half of heavy ball's bound 2 (1 + 0.9) = 3.8 would do; 1 leaves room for the data's
/// curvature on top.
pub const PENALTY_STEP_BOUND: f64 = 1.0;

/// Phase 1 (thesis 3.2): full-batch gradient descent with momentum 0.9 and learning rate
/// 0.01 on the penalised mean squared residual of [`Samples`] (`lambda`: the L2 weight
/// penalty of [`super::samples::objective`]), through burn's autodiff and SGD optimizer
/// (heavy-ball momentum: v <- 0.9 v + g, w <- w - 0.01 v). The penalty alone has curvature
/// c = 2 lambda / M (M residual components) along every weight, and heavy ball diverges where
/// rate c > 2 (1 + 0.9): where 0.01 c would exceed [`PENALTY_STEP_BOUND`] (lambda above 50 M)
/// the rate is lowered to bring it there, so that a large penalty shrinks the weights rather
/// than blowing them up (a reviewer's --penalty 1e6 on 150 rows diverged at epoch 5); below,
/// every penalty the search tries included, the thesis's 0.01 stands. Starts from `start`; calls
/// `epoch_done` with (epoch, training MSE without the penalty, weights) after each epoch and
/// stops when it returns false.
pub fn train_momentum(
    start: &Weights,
    s: &Samples,
    lambda: f64,
    epochs: usize,
    mut epoch_done: impl FnMut(usize, f64, &Weights) -> bool,
) -> Result<Weights> {
    let d = device(true)?;
    let (n, ni, no, nr) = (s.len(), start.inputs(), start.outputs(), s.rows());
    let xt = tensor2(s.x.iter().flatten().copied().collect(), n, ni, &d);
    let bt = tensor2(s.b.iter().flatten().copied().collect(), n, nr, &d);
    // A_k as one [n, rows, outputs] tensor; A_k y_k = sum over outputs of A_k * y_k broadcast.
    let maps: Option<Tensor<3>> = s.maps.as_ref().map(|m| {
        let data: Vec<f64> = m
            .iter()
            .flat_map(|a| (0..nr).flat_map(move |r| (0..no).map(move |c| a[(r, c)])))
            .collect();
        Tensor::from_data(TensorData::new(data, [n, nr, no]), &d)
    });
    let mut model = Mlp::new(&d, ni, start.hidden(), no).with_weights(start, &d);
    let mut optim = SgdConfig::new()
        .with_momentum(Some(
            MomentumConfig::new().with_momentum(0.9).with_dampening(0.0),
        ))
        .init();
    let components = (n * nr).max(1) as f64;
    let rate = LEARNING_RATE.min(PENALTY_STEP_BOUND * components / (2.0 * lambda.max(1e-300)));
    let mut current = start.clone();
    for epoch in 1..=epochs {
        let y = model.forward(xt.clone());
        let pred = match &maps {
            None => y,
            Some(a) => {
                let y3: Tensor<3> = y.reshape([n, 1, no]);
                let ay: Tensor<3> = a.clone().mul(y3).sum_dim(2);
                ay.reshape([n, nr])
            }
        };
        let mse_t = MseLoss::new().forward(pred, bt.clone(), Reduction::Mean);
        let mse: f64 = mse_t.clone().into_scalar::<f64>();
        let loss = if lambda > 0.0 {
            let w2 = model.hidden.weight.val().powi_scalar(2).sum()
                + model.out.weight.val().powi_scalar(2).sum();
            mse_t + w2.mul_scalar(lambda / (n * nr) as f64)
        } else {
            mse_t
        };
        if !mse.is_finite() {
            return Err(Error::NotConverged(format!(
                "network training diverged at epoch {epoch}: MSE {mse}"
            )));
        }
        let grads = GradientsParams::from_grads(loss.backward(), &model);
        model = optim.step(rate, model, grads);
        current = model.weights()?;
        if !epoch_done(epoch, mse, &current) {
            break;
        }
    }
    Ok(current)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn weights(ni: usize, nh: usize, no: usize, s: f64) -> Weights {
        Weights {
            w1: DMatrix::from_fn(nh, ni, |i, j| ((i * 5 + j) as f64 * s).sin() * 0.8),
            b1: DVector::from_fn(nh, |i, _| (i as f64 * s).cos() * 0.3),
            w2: DMatrix::from_fn(no, nh, |i, j| ((i + 3 * j) as f64 * s).cos() * 0.5),
            b2: DVector::from_fn(no, |i, _| i as f64 * 0.1),
        }
    }

    #[test]
    fn burn_module_and_record_hold_the_same_weights() {
        let w = weights(3, 5, 2, 0.7);
        let d = device(false).unwrap();
        let m = Mlp::new(&d, 3, 5, 2).with_weights(&w, &d);
        // burn's forward equals ours.
        let x = [0.2, -0.4, 0.9];
        let y = read2(m.forward(tensor2(x.to_vec(), 1, 3, &d))).unwrap();
        let ours = w.forward(&x);
        assert!(
            (y[0] - ours[0]).abs() < 1e-12 && (y[1] - ours[1]).abs() < 1e-12,
            "{y:?} vs {ours:?}"
        );
        assert_eq!(m.weights().unwrap(), w);
        let bytes = record_bytes(&w).unwrap();
        assert_eq!(weights_from_record(&bytes, 3, 5, 2).unwrap(), w);
        // The same weights give the same bytes (a compensator file is reproducible).
        assert_eq!(record_bytes(&w).unwrap(), bytes);
        assert!(weights_from_record(&bytes, 3, 6, 2).is_err());
        assert!(weights_from_record(&bytes[..bytes.len() / 2], 3, 5, 2).is_err());
    }

    #[test]
    fn momentum_phase_lowers_the_error() {
        let x: Vec<Vec<f64>> = (0..40).map(|k| vec![k as f64 / 20.0 - 1.0]).collect();
        let y: Vec<Vec<f64>> = x.iter().map(|v| vec![(2.0 * v[0]).sin()]).collect();
        let start = weights(1, 8, 1, 0.3);
        let mut first = f64::NAN;
        let mut last = f64::NAN;
        let s = Samples {
            x,
            b: y,
            ..Default::default()
        };
        train_momentum(&start, &s, 0.0, 300, |e, mse, _| {
            if e == 1 {
                first = mse;
            }
            last = mse;
            true
        })
        .unwrap();
        assert!(last < 0.3 * first, "{first} -> {last}");
    }

    #[test]
    fn momentum_loss_through_maps_equals_the_direct_sum() {
        // burn's batched A_k y_k (broadcast multiply and sum) against the plain loop.
        let start = weights(2, 4, 3, 0.45);
        let mut s = Samples {
            maps: Some(Vec::new()),
            ..Default::default()
        };
        let mut direct = 0.0;
        for k in 0..7 {
            let x = vec![k as f64 * 0.2 - 0.6, (k as f64).cos()];
            let a = DMatrix::from_fn(2, 3, |i, j| ((k * 6 + i * 3 + j) as f64).sin());
            let b = vec![0.3 * k as f64, -0.1];
            let y = DVector::from_vec(start.forward(&x));
            let r = DVector::from_column_slice(&b) - &a * y;
            direct += r.norm_squared();
            s.x.push(x);
            s.b.push(b);
            s.maps.as_mut().unwrap().push(a);
        }
        direct /= 14.0;
        let mut first = f64::NAN;
        train_momentum(&start, &s, 0.0, 1, |_, mse, _| {
            first = mse;
            true
        })
        .unwrap();
        assert!(
            (first - direct).abs() < 1e-12 * direct,
            "{first} vs {direct}"
        );
    }

    #[test]
    fn first_momentum_step_follows_the_penalised_gradient() {
        // burn's first heavy-ball step is w - 0.01 g, g the gradient of the penalised loss:
        // burn's autodiff and our backpropagation (samples::objective) must agree.
        let start = weights(2, 4, 3, 0.45);
        let mut s = Samples {
            maps: Some(Vec::new()),
            ..Default::default()
        };
        for k in 0..6 {
            s.x.push(vec![k as f64 * 0.3 - 0.8, (k as f64 * 0.7).sin()]);
            s.b.push(vec![0.2 * k as f64, -0.4]);
            s.maps
                .as_mut()
                .unwrap()
                .push(DMatrix::from_fn(2, 3, |i, j| {
                    ((k + 2 * i + j) as f64).cos()
                }));
        }
        let lambda = 0.3;
        let mut g = DVector::zeros(start.len());
        crate::neural::samples::objective(&s, &start, lambda, &mut g);
        let after = train_momentum(&start, &s, lambda, 1, |_, _, _| true).unwrap();
        let expected = start.to_vector() - g * 0.01;
        let got = after.to_vector();
        assert!((got - &expected).amax() < 1e-12, "{expected}");
    }

    #[test]
    fn a_penalty_beyond_the_stable_step_shrinks_the_weights() {
        // lambda 1e7 on 8 samples of 2 components: the rate 0.01 would step 0.01 x 2e7 / 16
        // = 12500 times the weights along the penalty, and diverge; the lowered rate takes
        // the penalised objective down and the penalised weights toward 0.
        let start = weights(2, 4, 2, 0.45);
        let s = Samples {
            x: (0..8)
                .map(|k| vec![k as f64 * 0.2 - 0.7, (k as f64).sin()])
                .collect(),
            b: (0..8)
                .map(|k| vec![0.1 * k as f64, (k as f64).cos()])
                .collect(),
            ..Default::default()
        };
        let lambda = 1e7;
        let mut g = DVector::zeros(start.len());
        let f0 = crate::neural::samples::objective(&s, &start, lambda, &mut g);
        let after = train_momentum(&start, &s, lambda, 200, |_, mse, _| {
            assert!(mse.is_finite());
            true
        })
        .unwrap();
        let f1 = crate::neural::samples::objective(&s, &after, lambda, &mut g);
        assert!(f1 < 1e-3 * f0, "{f0} -> {f1}");
        let norm = |w: &Weights| w.w1.norm_squared() + w.w2.norm_squared();
        assert!(norm(&after) < 1e-6 * norm(&start), "{}", norm(&after));
    }
}
