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
