//! Sensor models after real LiDARs, for the rig zoo. Channels are spread evenly over each
//! model's vertical field of view; where the real sensor crowds them (near the horizon), the doc
//! says so. Noise is the datasheet's range accuracy taken as one sigma.

use super::lidar::Lidar;
use super::rosette::Rosette;

const D: f64 = std::f64::consts::PI / 180.0;

impl Lidar {
    /// Velodyne HDL-32E-like: 32 channels over -30.67..+10.67 deg (evenly 1.33 deg apart, as
    /// the real one), 1800 columns (0.2 deg), 100 m, 2 cm noise.
    pub fn hdl_32e() -> Self {
        Self::uniform(32, -30.67 * D, 10.67 * D, 1800, 100.0, 0.02)
    }

    /// Velodyne VLP-16-like: 16 channels over -15..+15 deg (2 deg apart, as the real one), 1800
    /// columns (0.2 deg), 100 m, 3 cm noise.
    pub fn vlp_16() -> Self {
        Self::uniform(16, -15.0 * D, 15.0 * D, 1800, 100.0, 0.03)
    }

    /// Ouster OS1-64-like: 64 channels over -22.5..+22.5 deg, 1024 columns, 120 m, 2 cm noise.
    pub fn os1_64() -> Self {
        Self::uniform(64, -22.5 * D, 22.5 * D, 1024, 120.0, 0.02)
    }

    /// Hesai Pandar64-like: 64 channels over -25..+15 deg (the real one crowds them between -6
    /// and +2 deg; OpenCalib's scan spans -24.8..+15.0), 1800 columns (0.2 deg), 200 m, 2 cm
    /// noise.
    pub fn pandar_64() -> Self {
        Self::uniform(64, -25.0 * D, 15.0 * D, 1800, 200.0, 0.02)
    }

    /// Hesai PandarQT-like short-range unit: 64 channels over -52.1..+52.1 deg (its 104.2 deg,
    /// as OpenCalib's QT scans span), 600 columns (0.6 deg), 60 m (the datasheet's 20 m holds
    /// at 10 % reflectivity; OpenCalib's QT scans reach 45 m), 3 cm noise.
    pub fn pandar_qt() -> Self {
        Self::uniform(64, -52.1 * D, 52.1 * D, 600, 60.0, 0.03)
    }

    /// Livox Mid-40-like rosette scanner integrating `points` shots a frame
    /// ([`Rosette::mid40`]).
    pub fn mid_40(points: usize) -> Self {
        Self::Rosette(Rosette::mid40(points))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn models_span_their_datasheet_fields_of_view() {
        for (lidar, channels, top, bottom, range) in [
            (Lidar::hdl_32e(), 32, 10.67, -30.67, 100.0),
            (Lidar::vlp_16(), 16, 15.0, -15.0, 100.0),
            (Lidar::os1_64(), 64, 22.5, -22.5, 120.0),
            (Lidar::pandar_64(), 64, 15.0, -25.0, 200.0),
            (Lidar::pandar_qt(), 64, 52.1, -52.1, 60.0),
        ] {
            let s = lidar.spinning().expect("spinning");
            assert_eq!((s.height(), s.max_range, s.float16), (channels, range, false));
            let (first, last) = (s.vertical_angles[0], s.vertical_angles[channels - 1]);
            assert!((first / D - top).abs() < 1e-9 && (last / D - bottom).abs() < 1e-9);
        }
        let mid = Lidar::mid_40(1000);
        assert_eq!((mid.width(), mid.height(), mid.max_range()), (1000, 1, 90.0));
    }
}
