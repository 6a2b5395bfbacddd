//! RGB triples for reflectance, emission and radiosity (one value per channel).

/// An RGB triple in linear units (reflectance in [0, 1), exitance in W·m⁻²).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rgb(pub [f64; 3]);

impl Rgb {
    pub const BLACK: Rgb = Rgb([0.0; 3]);

    /// Largest channel.
    pub fn max_channel(self) -> f64 {
        self.0[0].max(self.0[1]).max(self.0[2])
    }

    /// True when every channel is finite.
    pub fn is_finite(self) -> bool {
        self.0.iter().all(|c| c.is_finite())
    }
}
