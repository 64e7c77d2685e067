//! Colors and colormaps.

/// An sRGB color.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Color(pub u8, pub u8, pub u8);

impl Color {
    /// `#rrggbb`.
    pub fn hex(&self) -> String {
        format!("#{:02x}{:02x}{:02x}", self.0, self.1, self.2)
    }

    fn lerp(a: Color, b: Color, t: f64) -> Color {
        let m = |x: u8, y: u8| (f64::from(x) + (f64::from(y) - f64::from(x)) * t).round() as u8;
        Color(m(a.0, b.0), m(a.1, b.1), m(a.2, b.2))
    }
}

/// Series colors, used in turn (Tableau 10).
pub const PALETTE: [Color; 10] = [
    Color(0x1f, 0x77, 0xb4),
    Color(0xd6, 0x27, 0x28),
    Color(0x2c, 0xa0, 0x2c),
    Color(0xff, 0x7f, 0x0e),
    Color(0x94, 0x67, 0xbd),
    Color(0x8c, 0x56, 0x4b),
    Color(0xe3, 0x77, 0xc2),
    Color(0x7f, 0x7f, 0x7f),
    Color(0xbc, 0xbd, 0x22),
    Color(0x17, 0xbe, 0xcf),
];

/// Maps a value in [0, 1] to a color.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Colormap {
    /// Perceptually uniform dark blue -> green -> yellow (matplotlib's viridis, 9 stops).
    #[default]
    Viridis,
    /// Light gray -> dark red: zero stands out as "no contact", large values as strong contact.
    GrayRed,
    /// Blue -> white -> red, for signed data centered on the middle of the range.
    Diverging,
}

impl Colormap {
    fn stops(&self) -> &'static [Color] {
        const VIRIDIS: [Color; 9] = [
            Color(0x44, 0x01, 0x54),
            Color(0x47, 0x2c, 0x7a),
            Color(0x3b, 0x51, 0x8b),
            Color(0x2c, 0x71, 0x8e),
            Color(0x21, 0x90, 0x8d),
            Color(0x27, 0xad, 0x81),
            Color(0x5c, 0xc8, 0x63),
            Color(0xaa, 0xdc, 0x32),
            Color(0xfd, 0xe7, 0x25),
        ];
        const GRAY_RED: [Color; 4] = [
            Color(0xee, 0xee, 0xee),
            Color(0xfc, 0xae, 0x91),
            Color(0xde, 0x2d, 0x26),
            Color(0x67, 0x00, 0x0d),
        ];
        const DIVERGING: [Color; 5] = [
            Color(0x21, 0x66, 0xac),
            Color(0x92, 0xc5, 0xde),
            Color(0xf7, 0xf7, 0xf7),
            Color(0xf4, 0xa5, 0x82),
            Color(0xb2, 0x18, 0x2b),
        ];
        match self {
            Colormap::Viridis => &VIRIDIS,
            Colormap::GrayRed => &GRAY_RED,
            Colormap::Diverging => &DIVERGING,
        }
    }

    /// The color at `t` (clamped to [0, 1]; NaN maps to 0).
    pub fn at(&self, t: f64) -> Color {
        let stops = self.stops();
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        let x = t * (stops.len() - 1) as f64;
        let i = (x.floor() as usize).min(stops.len() - 2);
        Color::lerp(stops[i], stops[i + 1], x - i as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colormap_ends_and_clamping() {
        assert_eq!(Colormap::Viridis.at(0.0), Color(0x44, 0x01, 0x54));
        assert_eq!(Colormap::Viridis.at(1.0), Color(0xfd, 0xe7, 0x25));
        assert_eq!(Colormap::Viridis.at(7.0), Colormap::Viridis.at(1.0));
        assert_eq!(Colormap::Diverging.at(0.5), Color(0xf7, 0xf7, 0xf7));
        assert_eq!(Colormap::GrayRed.at(-1.0), Color(0xee, 0xee, 0xee));
        assert_eq!(Color(255, 0, 16).hex(), "#ff0010");
    }
}
