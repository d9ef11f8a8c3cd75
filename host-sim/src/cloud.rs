//! Host-side point records, common to the core, the reference and the writers.

/// One point of a processed frame.
#[derive(Clone, Copy, Debug, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct PointRecord {
    /// x forward, m.
    pub x: f64,
    /// y left, m.
    pub y: f64,
    /// z up, m.
    pub z: f64,
    /// Radial velocity, m/s, positive receding.
    pub doppler: f64,
    /// Capon power, dB.
    pub intensity_db: f64,
    /// RA-map power over the CFAR level, dB.
    pub snr_db: f64,
    /// Range bin.
    pub range_bin: u32,
    /// Azimuth grid bin.
    pub azimuth_bin: u32,
    /// Elevation grid bin.
    pub elevation_bin: u32,
    /// Signed Doppler bin.
    pub doppler_bin: i32,
}

impl From<&dbe_radar::Point> for PointRecord {
    fn from(p: &dbe_radar::Point) -> Self {
        Self {
            x: f64::from(p.position.x),
            y: f64::from(p.position.y),
            z: f64::from(p.position.z),
            doppler: f64::from(p.velocity_mps),
            intensity_db: f64::from(p.power_db),
            snr_db: f64::from(p.snr_db),
            range_bin: u32::from(p.range_bin),
            azimuth_bin: u32::from(p.azimuth_bin),
            elevation_bin: u32::from(p.elevation_bin),
            doppler_bin: i32::from(p.doppler_bin),
        }
    }
}

impl PointRecord {
    /// The fields the core's later stages read (position, velocity, power, SNR) as a core
    /// [`dbe_radar::Point`], e.g. to run the ego-velocity stage on host output; bins are
    /// clamped into the core's integer types.
    pub fn to_point(&self) -> dbe_radar::Point {
        dbe_radar::Point {
            position: dbe_radar::Vec3::new(self.x as f32, self.y as f32, self.z as f32),
            velocity_mps: self.doppler as f32,
            power_db: self.intensity_db as f32,
            snr_db: self.snr_db as f32,
            range_bin: self.range_bin.min(u32::from(u16::MAX)) as u16,
            azimuth_bin: self.azimuth_bin.min(u32::from(u16::MAX)) as u16,
            elevation_bin: self.elevation_bin.min(u32::from(u16::MAX)) as u16,
            doppler_bin: self.doppler_bin.clamp(i16::MIN.into(), i16::MAX.into()) as i16,
        }
    }
}
