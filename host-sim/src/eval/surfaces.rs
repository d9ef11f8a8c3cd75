//! Realistic surfaces (issue 10 §5): every extended scene with the plain diffuse surfaces and
//! with [`crate::sim::SurfaceModel::realistic`] (specular lobe, edges, corners, floor ghosts),
//! side by side, and which comparisons between the chains come out differently with them.

use serde::Serialize;

use super::names;
use super::scenarios::{SceneFile, SCENES};
use super::tables::{mean, same, Evaluation, EXTENDED_SCENES};

/// Threshold of the paper's CD(τ) shown beside the other metrics, m.
pub const PAPER_TAU_M: f64 = 0.1;

/// One extended scene with one surface model: both chains' defaults.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SurfaceRow {
    /// The scene file (without the `_realistic` suffix).
    pub scene: String,
    /// With the realistic surfaces.
    pub realistic: bool,
    /// Points per frame, DBE / FFT.
    pub points: [Option<f64>; 2],
    /// False points per frame (> 0.6 m from every truth point), DBE / FFT.
    pub false_points: [Option<f64>; 2],
    /// Per-frame Chamfer accuracy term at the sweep's resolution, m, DBE / FFT.
    pub accuracy_m: [Option<f64>; 2],
    /// Per-frame mean Chamfer distance at the sweep's resolution, m, DBE / FFT.
    pub chamfer_m: [Option<f64>; 2],
    /// The paper's CD([`PAPER_TAU_M`]) on the sequence maps, exact poses, m, DBE / FFT.
    pub chamfer_paper_m: [Option<f64>; 2],
    /// Symmetric mean Chamfer distance of the sequence maps at the sweep's resolution, m.
    pub chamfer_map_m: [Option<f64>; 2],
}

/// One comparison between the chains, counted over the four scenes with each surface model.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Conclusion {
    /// What is compared ("DBE ... than FFT").
    pub claim: String,
    /// Scenes where it holds with the plain surfaces.
    pub plain: Vec<String>,
    /// Scenes where it holds with the realistic surfaces.
    pub realistic: Vec<String>,
}

impl Conclusion {
    /// Whether any scene's verdict differs between the two surface models.
    pub fn changes(&self) -> bool {
        self.plain != self.realistic
    }
}

fn extended() -> &'static [SceneFile] {
    &SCENES[..EXTENDED_SCENES]
}

/// The rows, plain then realistic per scene, in [`SCENES`] order of the plain scenes.
pub fn rows(e: &Evaluation) -> Vec<SurfaceRow> {
    let res = e.defaults_resolution_m;
    let mut out = Vec::new();
    for plain in extended().iter().filter(|s| !s.realistic) {
        for twin in extended().iter().filter(|s| s.base_name() == plain.name) {
            let s = twin.name;
            let both = |g: &dyn Fn(&str) -> Option<f64>| [g(names::DBE), g(names::FFT)];
            let paper = e
                .chamfer_paper
                .iter()
                .find(|r| r.scene == s && same(r.tau, PAPER_TAU_M));
            let map = e
                .chamfer_map
                .iter()
                .find(|r| r.scene == s && same(r.resolution, res));
            out.push(SurfaceRow {
                scene: plain.name.to_string(),
                realistic: twin.realistic,
                points: both(&|v| e.scene_at(s, v).map(|r| r.points_per_frame)),
                false_points: both(&|v| e.scene_at(s, v).map(|r| r.false_points_per_frame)),
                accuracy_m: both(&|v| e.chamfer_at(s, res, v).and_then(|r| r.accuracy_m)),
                chamfer_m: both(&|v| e.chamfer_at(s, res, v).and_then(|r| r.chamfer_m)),
                chamfer_paper_m: [paper.and_then(|r| r.dbe), paper.and_then(|r| r.fft)],
                chamfer_map_m: [map.and_then(|r| r.dbe), map.and_then(|r| r.fft)],
            });
        }
    }
    out
}

/// The chain comparisons of the goals, per surface model; a comparison with a missing value
/// does not hold.
pub fn conclusions(rows: &[SurfaceRow]) -> Vec<Conclusion> {
    type Test = fn(&SurfaceRow) -> Option<bool>;
    let claims: [(&str, Test); 6] = [
        ("DBE gives at least as many points per frame as FFT", |r| {
            Some(r.points[0]? >= r.points[1]?)
        }),
        ("DBE gives no more false points per frame than FFT", |r| {
            Some(r.false_points[0]? <= r.false_points[1]?)
        }),
        ("DBE accuracy term ≤ 0.8× FFT's", |r| {
            Some(r.accuracy_m[0]? <= 0.8 * r.accuracy_m[1]?)
        }),
        ("DBE below FFT in per-frame Chamfer distance", |r| {
            Some(r.chamfer_m[0]? < r.chamfer_m[1]?)
        }),
        (
            "DBE below FFT in the paper's CD(τ = 0.1 m) on sequence maps",
            |r| Some(r.chamfer_paper_m[0]? < r.chamfer_paper_m[1]?),
        ),
        (
            "DBE below FFT in symmetric Chamfer distance on sequence maps",
            |r| Some(r.chamfer_map_m[0]? < r.chamfer_map_m[1]?),
        ),
    ];
    claims
        .iter()
        .map(|(claim, test)| {
            let holds = |realistic: bool| {
                rows.iter()
                    .filter(|r| r.realistic == realistic && test(r) == Some(true))
                    .map(|r| r.scene.clone())
                    .collect()
            };
            Conclusion {
                claim: claim.to_string(),
                plain: holds(false),
                realistic: holds(true),
            }
        })
        .collect()
}

/// The CFAR α of the defaults sweep with the lowest mean per-frame Chamfer distance over the
/// plain (`realistic = false`) or realistic scenes ([`Evaluation::best_alpha_over`]), with
/// that mean and the mean false points per frame there: `(α, Chamfer m, false points)`.
pub fn best_alpha(e: &Evaluation, realistic: bool) -> Option<(String, f64, f64)> {
    let scenes: Vec<&SceneFile> = extended()
        .iter()
        .filter(|s| s.realistic == realistic)
        .collect();
    let (row, cd) = e.best_alpha_over(&scenes)?;
    let fp = scenes
        .iter()
        .map(|s| Some(e.scene_at(s.name, &row.variant)?.false_points_per_frame))
        .collect::<Option<Vec<f64>>>()?;
    Some((row.value.clone(), cd, mean(fp)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(scene: &str, realistic: bool, dbe_points: f64) -> SurfaceRow {
        SurfaceRow {
            scene: scene.into(),
            realistic,
            points: [Some(dbe_points), Some(10.0)],
            false_points: [Some(0.0), None],
            accuracy_m: [Some(0.08), Some(0.1)],
            chamfer_m: [Some(1.0), Some(1.0)],
            chamfer_paper_m: [None, Some(0.1)],
            chamfer_map_m: [Some(0.5), Some(0.6)],
        }
    }

    #[test]
    fn a_conclusion_changes_only_where_a_scene_verdict_flips() {
        let rows = [
            row("a", false, 12.0),
            row("a", true, 8.0),
            row("b", false, 10.0),
            row("b", true, 10.0),
        ];
        let c = conclusions(&rows);
        let by = |claim: &str| c.iter().find(|c| c.claim.starts_with(claim)).expect(claim);
        // Points: a ≥ on plain only, b equal on both (≥ holds).
        let points = by("DBE gives at least as many points");
        assert_eq!(points.plain, ["a", "b"]);
        assert_eq!(points.realistic, ["b"]);
        assert!(points.changes());
        // 0.08 ≤ 0.8 × 0.1 everywhere; equal Chamfer is not "below"; a missing value never holds.
        assert!(!by("DBE accuracy term").changes());
        assert_eq!(by("DBE accuracy term").plain, ["a", "b"]);
        assert!(by("DBE below FFT in per-frame").plain.is_empty());
        assert!(by("DBE gives no more false").realistic.is_empty());
        assert!(by("DBE below FFT in the paper").plain.is_empty());
        assert_eq!(by("DBE below FFT in symmetric").realistic, ["a", "b"]);
    }
}
