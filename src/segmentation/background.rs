//! The background threshold: voxels below it are air (label 0) and are never evaluated.
//!
//! Automatic rule: Otsu's threshold of the volume's 256-bin histogram
//! ([`Volume::otsu_threshold`], computed once per volume; it splits air from everything else
//! in CT and MRI alike), lowered to the lowest training intensity so that
//! nothing the user marked as a class can fall into the background. A user who lassoes air
//! as a class therefore gets every voxel classified.

use crate::volume::Volume;

/// How the background is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Background {
    /// Otsu's threshold, at most the lowest training intensity.
    Automatic,
    /// Voxels below this physical value are background.
    Below(f64),
    /// Every voxel is classified.
    None,
}

impl Background {
    /// The threshold for `volume`, given the lowest intensity among the training voxels.
    pub fn threshold(self, volume: &Volume, lowest_training_value: f64) -> Option<f64> {
        match self {
            Background::Automatic => Some(volume.otsu_threshold().min(lowest_training_value)),
            Background::Below(value) => Some(value),
            Background::None => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn the_automatic_threshold_never_drops_training_voxels_into_the_background() {
        // 70% air around -1000, 30% tissue around 40.
        let values: Vec<f32> =
            (0..1000).map(|i| if i % 10 < 7 { -1000.0 + (i % 7) as f32 } else { 40.0 + (i % 3) as f32 }).collect();
        let volume = Volume::from_f32([10, 10, 10], [1.0; 3], &values, Path::new("t")).unwrap();
        let otsu = volume.otsu_threshold();
        assert_eq!(Background::Automatic.threshold(&volume, 1000.0), Some(otsu));
        assert_eq!(Background::Automatic.threshold(&volume, -995.0), Some(-995.0), "training voxels stay classified");
        assert_eq!(Background::Below(3.0).threshold(&volume, -995.0), Some(3.0));
        assert_eq!(Background::None.threshold(&volume, 0.0), None);
    }
}
