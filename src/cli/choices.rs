//! The command line's spellings of the library's choices (clap value enums): the library's
//! own enums carry no clap derive. Each converts into its library value with `From`.

use clap::ValueEnum;

macro_rules! choice {
    ($(#[$doc:meta])* $name:ident => $lib:ty { $($(#[$vdoc:meta])* $variant:ident),+ $(,)? }) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
        pub enum $name {
            $($(#[$vdoc])* $variant),+
        }

        impl From<$name> for $lib {
            fn from(c: $name) -> Self {
                type L = $lib;
                match c {
                    $($name::$variant => L::$variant),+
                }
            }
        }
    };
}

choice! {
    /// What each measurement row gives.
    Measure => robocal::identify::Measure {
        /// Position and orientation of each row.
        Pose,
        /// Position of each row.
        Position,
        /// Orientation of each row.
        Orientation,
        /// Displacement p(a) - p(b) of each pair of rows.
        Relative,
        /// Length of that displacement (a ball-bar's distance).
        Distance,
    }
}

choice! {
    /// The robust loss of iteratively reweighted least squares.
    RobustLoss => robocal::identify::RobustLoss {
        /// Quadratic within k robust sigmas, linear beyond (k = 1.345).
        Huber,
        /// Logarithmic: w = 1 / (1 + (u/k)^2) (k = 2.385).
        Cauchy,
    }
}

choice! {
    /// The least-squares method.
    Method => robocal::identify::Method {
        /// Levenberg-Marquardt.
        Lm,
        /// Gauss-Newton with step halving.
        Gn,
        /// Nelder-Mead simplex (derivative free, thesis 4.1).
        Nm,
    }
}

choice! {
    /// What the simulated sensor reports.
    Observe => robocal::sim::Observe {
        /// Position and orientation.
        Pose,
        /// Position only.
        Position,
        /// Orientation only.
        Orientation,
    }
}

choice! {
    /// Where the network's output acts.
    Form => robocal::neural::settings::Form {
        /// Pose residual at the tool (robot base frame).
        Pose,
        /// Joint corrections before FK.
        Joint,
    }
}

choice! {
    /// What kind of network a compensator carries.
    Network => robocal::neural::settings::Network {
        /// The thesis's multilayer perceptron: one logistic hidden layer, trained by momentum
        /// then Levenberg-Marquardt where its normal matrix is small, else L-BFGS (--phase2; an
        /// ensemble of them where it helps).
        Mlp,
        /// A radial-basis-function network with one unit per training row, at most
        /// --rbf-units (a Gaussian process's posterior mean); pose form only.
        Rbf,
        /// The MLPs' mean and an RBF network blended, the MLPs' share chosen by
        /// cross-validation or fixed by --mlp-share (pose form only).
        Mix,
    }
}

choice! {
    /// What a measurement plan optimises.
    Criterion => robocal::plan::Criterion {
        /// D-optimal: the determinant of the information matrix.
        D,
        /// Borm and Menq's O1 (plans as D).
        O1,
        /// Nahvi and Hollerbach's O3: the smallest singular value.
        O3,
        /// A-optimal: the sum of the parameters' variances (scaled), minimised (printed as
        /// its negative).
        A,
        /// I-optimal: the predicted mean squared position error over the validation cloud,
        /// minimised (printed as its root, the RMS in mm).
        I,
    }
}

choice! {
    /// The RBF network's covariance function.
    RbfKernel => robocal::neural::rbf::Covariance {
        /// Matern nu = 5/2: (1 + t + t^2/3) e^-t, t = sqrt(5 q) (the default).
        Matern52,
        /// Squared exponential exp(-q/2) (networks before version 7 of the file).
        SquaredExponential,
    }
}
