//! The eight landmark models of the paper (§4.1, §5.1): four shape primitives and four
//! 6-segment piecewise-linear shapes.

use serde::{Deserialize, Serialize};

/// A landmark model: which function of the genome gives the landmark's profile.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LandmarkModel {
    /// P1, triangle: apex of height H at the centre, base W on the wall.
    P1Triangle,
    /// P2, rectangle: a box W wide standing H out of the wall.
    P2Rectangle,
    /// P3, parabola: `H · (1 − (2u/W)²)`.
    P3Parabola,
    /// P4, linear ramp: rises from 0 at `u = −W/2` to H at `u = +W/2`, then steps back to the wall.
    P4Ramp,
    /// F1, free 6-segment piecewise-linear shape `H · s(u)`.
    F1Free,
    /// F2, inverted free shape `H · (1 − s(u))`.
    F2Inverted,
    /// F3, symmetric (even) free shape.
    F3Symmetric,
    /// F4, symmetric inverted free shape (the paper's "W"-like optimum).
    F4SymmetricInverted,
}

impl LandmarkModel {
    /// All eight models, P1…P4 then F1…F4.
    pub const ALL: [LandmarkModel; 8] = [
        LandmarkModel::P1Triangle,
        LandmarkModel::P2Rectangle,
        LandmarkModel::P3Parabola,
        LandmarkModel::P4Ramp,
        LandmarkModel::F1Free,
        LandmarkModel::F2Inverted,
        LandmarkModel::F3Symmetric,
        LandmarkModel::F4SymmetricInverted,
    ];

    /// True for the piecewise-linear models F1…F4 (genome {W, H, D, h1…h6}).
    #[inline]
    pub fn is_piecewise(self) -> bool {
        matches!(
            self,
            LandmarkModel::F1Free
                | LandmarkModel::F2Inverted
                | LandmarkModel::F3Symmetric
                | LandmarkModel::F4SymmetricInverted
        )
    }

    /// True for F2 and F4 (profile `1 − s(u)`).
    #[inline]
    pub fn is_inverted(self) -> bool {
        matches!(
            self,
            LandmarkModel::F2Inverted | LandmarkModel::F4SymmetricInverted
        )
    }

    /// True for F3 and F4 (even profile).
    #[inline]
    pub fn is_symmetric(self) -> bool {
        matches!(
            self,
            LandmarkModel::F3Symmetric | LandmarkModel::F4SymmetricInverted
        )
    }

    /// Number of genes the model uses: 3 ({W, H, D}) or 9 ({W, H, D, h1…h6}).
    #[inline]
    pub fn gene_count(self) -> usize {
        if self.is_piecewise() {
            9
        } else {
            3
        }
    }

    /// The paper's short name: "P1" … "F4".
    pub fn code(self) -> &'static str {
        match self {
            LandmarkModel::P1Triangle => "P1",
            LandmarkModel::P2Rectangle => "P2",
            LandmarkModel::P3Parabola => "P3",
            LandmarkModel::P4Ramp => "P4",
            LandmarkModel::F1Free => "F1",
            LandmarkModel::F2Inverted => "F2",
            LandmarkModel::F3Symmetric => "F3",
            LandmarkModel::F4SymmetricInverted => "F4",
        }
    }

    /// The model with short name `code` ("P1" … "F4", case-insensitive), if any.
    pub fn from_code(code: &str) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|m| m.code().eq_ignore_ascii_case(code))
    }

    /// Stable one-byte tag used by the map file format (0…7 in [`LandmarkModel::ALL`] order).
    #[inline]
    pub fn tag(self) -> u8 {
        match self {
            LandmarkModel::P1Triangle => 0,
            LandmarkModel::P2Rectangle => 1,
            LandmarkModel::P3Parabola => 2,
            LandmarkModel::P4Ramp => 3,
            LandmarkModel::F1Free => 4,
            LandmarkModel::F2Inverted => 5,
            LandmarkModel::F3Symmetric => 6,
            LandmarkModel::F4SymmetricInverted => 7,
        }
    }

    /// The model with file-format tag `tag`, if any.
    #[inline]
    pub fn from_tag(tag: u8) -> Option<Self> {
        Self::ALL.get(usize::from(tag)).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tags_and_codes_round_trip() {
        for m in LandmarkModel::ALL {
            assert_eq!(LandmarkModel::from_tag(m.tag()), Some(m));
            assert_eq!(LandmarkModel::from_code(m.code()), Some(m));
        }
        assert_eq!(LandmarkModel::from_tag(8), None);
        assert_eq!(
            LandmarkModel::from_code("f4"),
            Some(LandmarkModel::F4SymmetricInverted)
        );
        assert_eq!(LandmarkModel::F4SymmetricInverted.gene_count(), 9);
        assert_eq!(LandmarkModel::P3Parabola.gene_count(), 3);
    }
}
