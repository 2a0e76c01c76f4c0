//! The MLPs' share in a blend with the RBF network, chosen by cross-validation among
//! [`super::SHARES`]: held-out sums are kept per share and the share of least error is taken.

use crate::neural::selection::Sums;
use crate::neural::settings::{Network, Settings};

/// Whether `s` is a mixed network whose MLP share cross-validation chooses (scored at each
/// of [`super::SHARES`]).
pub(super) fn open_share(s: &Settings) -> bool {
    s.network == Network::Mix && s.mlp_share.is_none() && s.members > 0
}

/// `total += x`, share by share (`total` empty: `x`).
pub(super) fn add_shares(total: &mut Vec<Sums>, x: &[Sums]) {
    if total.is_empty() {
        total.resize(x.len(), Sums::default());
    }
    total.iter_mut().zip(x).for_each(|(t, v)| t.add(*v));
}

/// The share of lowest summed squared position error (the first of equals) and its sums;
/// empty sums for none.
pub(super) fn best_share(t: &[Sums]) -> (usize, Sums) {
    let mut best = 0;
    for (i, x) in t.iter().enumerate() {
        if x.pos < t[best].pos {
            best = i;
        }
    }
    (best, t.get(best).copied().unwrap_or_default())
}
