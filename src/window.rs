//! Window functions for the range and Doppler FFTs.

/// A window applied before an FFT. All windows are the *symmetric* forms (as
/// `numpy.blackman(N)`): `w[n]` for `n = 0..N` with the period `N − 1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WindowKind {
    /// All ones.
    Rectangular,
    /// `0.5 − 0.5·cos(2πn/(N−1))`.
    Hann,
    /// `0.54 − 0.46·cos(2πn/(N−1))`.
    Hamming,
    /// `0.42 − 0.5·cos(2πn/(N−1)) + 0.08·cos(4πn/(N−1))` (spec §3 default for range).
    #[default]
    Blackman,
}

impl WindowKind {
    /// The window's `N` coefficients.
    ///
    /// ```
    /// use dbe_radar::window::WindowKind;
    /// let w: [f32; 5] = WindowKind::Hann.coefficients();
    /// assert!((w[2] - 1.0).abs() < 1e-6 && w[0].abs() < 1e-6);
    /// ```
    pub fn coefficients<const N: usize>(self) -> [f32; N] {
        let mut w = [1.0f32; N];
        if N < 2 {
            return w;
        }
        let period = (N - 1) as f64;
        for (n, c) in w.iter_mut().enumerate() {
            let x = 2.0 * core::f64::consts::PI * n as f64 / period;
            *c = match self {
                WindowKind::Rectangular => 1.0,
                WindowKind::Hann => 0.5 - 0.5 * libm::cos(x),
                WindowKind::Hamming => 0.54 - 0.46 * libm::cos(x),
                WindowKind::Blackman => 0.42 - 0.5 * libm::cos(x) + 0.08 * libm::cos(2.0 * x),
            } as f32;
        }
        w
    }
}

/// A window's kind with its `N` coefficients, kept together: a peak interpolator must know
/// the main lobe's shape, so code that applies a window and then interpolates the peak takes
/// this one value and cannot pair coefficients with the wrong kind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Window<const N: usize> {
    kind: WindowKind,
    coefficients: [f32; N],
}

impl<const N: usize> Window<N> {
    /// The window of `kind`.
    ///
    /// ```
    /// use dbe_radar::window::{Window, WindowKind};
    /// let w = Window::<4>::new(WindowKind::Rectangular);
    /// assert_eq!(w.kind(), WindowKind::Rectangular);
    /// assert_eq!(w.coefficients(), &[1.0; 4]);
    /// ```
    pub fn new(kind: WindowKind) -> Self {
        Self {
            kind,
            coefficients: kind.coefficients(),
        }
    }

    /// All-zero coefficients (everything maps to zero), for `const` construction before a
    /// chain is configured.
    pub const fn unconfigured() -> Self {
        Self {
            kind: WindowKind::Rectangular,
            coefficients: [0.0; N],
        }
    }

    /// The window's kind.
    pub fn kind(&self) -> WindowKind {
        self.kind
    }

    /// The window's coefficients.
    pub fn coefficients(&self) -> &[f32; N] {
        &self.coefficients
    }
}
