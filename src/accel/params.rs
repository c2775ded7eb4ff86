//! One parameter model: every structure's parameters are a plain struct defined once, in
//! its own folder (`BuildParams`, `KdParams`, `GridParams`, `OctreeParams`), and
//! `StructureParams` gathers them with the choice of structure and the traversal settings.
//! Each struct derives what the front ends need: serde (the app's saved settings, the
//! presets' keys, a pinned configuration A) and clap (the CLI's flags, flattened into every
//! subcommand that builds, and the parser of `--compare`'s B). The app's controls are one
//! editor function per struct (`app/params.rs`).

use super::bvh::wide::UnsupportedSimd;
use super::grid::GridParams;
use super::kdtree::KdParams;
use super::octree::OctreeParams;
use super::structure::{AccelKind, StructureError};
use super::{BuildParams, TraversalOrder};
use crate::geometry::simd::SimdLevel;
use serde::{Deserialize, Serialize};

/// Everything a build and its traversal need, as plain data shared by the app, the CLI and
/// the tests. The parameters of every structure are kept, so switching back and forth keeps
/// each one's. Its keys are flat (`accel`, `strategy`, `kd_bins`, `grid_lambda`, …): the
/// presets and the saved settings spell them so.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, clap::Args)]
#[serde(default)]
pub struct StructureParams {
    /// The structure. A missing `accel` key means the fastest layout on this machine; the
    /// CLI sets it from `--accel` and the scene.
    #[serde(rename = "accel", default = "AccelKind::fastest")]
    #[arg(skip)]
    pub kind: AccelKind,
    #[serde(flatten)]
    #[command(flatten)]
    pub bvh: BuildParams,
    /// Child order in closest-hit traversal (a traversal setting: no rebuild).
    #[serde(rename = "naive_order", with = "naive_order")]
    #[arg(long, value_enum, default_value_t = TraversalOrder::FrontToBack)]
    pub order: TraversalOrder,
    #[serde(flatten)]
    #[command(flatten)]
    pub kdtree: KdParams,
    #[serde(flatten)]
    #[command(flatten)]
    pub grid: GridParams,
    #[serde(flatten)]
    #[command(flatten)]
    pub octree: OctreeParams,
    /// Spatial structures: test a triangle once per ray even if several cells hold it
    /// (`--mailbox false` to see the repeats). A traversal setting: no rebuild.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub mailbox: bool,
    /// BVH4/BVH8: the SIMD slab kernel (default: the widest this CPU has). A traversal
    /// setting: no rebuild.
    #[arg(long, value_enum, default_value_t = SimdLevel::detect())]
    pub simd: SimdLevel,
}

impl Default for StructureParams {
    fn default() -> Self {
        StructureParams {
            kind: AccelKind::Bvh,
            bvh: BuildParams::default(),
            order: TraversalOrder::FrontToBack,
            kdtree: KdParams::default(),
            grid: GridParams::default(),
            octree: OctreeParams::default(),
            mailbox: true,
            simd: SimdLevel::detect(),
        }
    }
}

impl StructureParams {
    pub fn of_kind(kind: AccelKind) -> Self {
        StructureParams {
            kind,
            ..Default::default()
        }
    }

    /// The C_trav and C_isect this structure's SAH cost is weighed with: the k-d tree's
    /// for the structures that walk cells (k-d tree, octree), the BVH's for the others.
    pub fn sah_constants(&self) -> (f32, f32) {
        match self.kind {
            AccelKind::KdTree | AccelKind::Octree => (self.kdtree.c_trav, self.kdtree.c_isect),
            _ => (self.bvh.c_trav, self.bvh.c_isect),
        }
    }

    /// Checks the parameters of the chosen structure.
    pub fn validate(&self) -> Result<(), StructureError> {
        match self.kind {
            AccelKind::Bvh => self.bvh.validate()?,
            AccelKind::Bvh4 | AccelKind::Bvh8 | AccelKind::TwoLevel => {
                self.bvh.validate()?;
                if !self.simd.supported() {
                    return Err(UnsupportedSimd(self.simd).into());
                }
            }
            AccelKind::KdTree => self.kdtree.validate()?,
            AccelKind::Grid => self.grid.validate()?,
            AccelKind::Octree => self.octree.validate()?,
            AccelKind::BruteForce | AccelKind::BruteForceBbox => {}
        }
        Ok(())
    }

    /// Whether a structure built with `self` must be built again to match `other`
    /// (traversal settings alone never need a build).
    pub fn needs_rebuild_for(&self, other: &StructureParams) -> bool {
        let strip = |p: &StructureParams| {
            let mut p = *p;
            p.order = TraversalOrder::FrontToBack;
            p.mailbox = true;
            p.simd = SimdLevel::Portable;
            p.kdtree.mailbox = true;
            p.grid.mailbox = true;
            p.octree.mailbox = true;
            p
        };
        let (a, b) = (strip(self), strip(other));
        a.kind != b.kind
            || match a.kind {
                AccelKind::Bvh | AccelKind::Bvh4 | AccelKind::Bvh8 | AccelKind::TwoLevel => {
                    a.bvh != b.bvh
                }
                AccelKind::KdTree => a.kdtree != b.kdtree,
                AccelKind::Grid => a.grid != b.grid,
                // The octree's report weighs its cells with the k-d tree's constants.
                AccelKind::Octree => a.octree != b.octree || a.sah_constants() != b.sah_constants(),
                AccelKind::BruteForce | AccelKind::BruteForceBbox => false,
            }
    }

    /// A short name: the structure and, for a BVH, its builder, leaf size and order; for a
    /// spatial structure, whether it mailboxes.
    pub fn label(&self) -> String {
        match self.kind {
            AccelKind::Bvh | AccelKind::Bvh4 | AccelKind::Bvh8 | AccelKind::TwoLevel => format!(
                "{}, {}, leaves ≤ {}, {}",
                self.kind.title(),
                self.bvh.strategy.label(),
                self.bvh.max_leaf_size,
                self.order.label()
            ),
            kind if kind.is_spatial() => format!(
                "{}, mailboxing {}",
                kind.title(),
                if self.mailbox { "on" } else { "off" }
            ),
            kind => kind.title().to_string(),
        }
    }
}

/// The traversal order as the presets spell it: `naive_order = true` or `false`.
mod naive_order {
    use super::TraversalOrder;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(order: &TraversalOrder, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bool(*order == TraversalOrder::Naive)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<TraversalOrder, D::Error> {
        Ok(if bool::deserialize(d)? {
            TraversalOrder::Naive
        } else {
            TraversalOrder::FrontToBack
        })
    }
}

/// A parameter of `StructureParams` that does nothing for its structure: its key (the
/// preset key, also its flag's id) and why, as "is the grid's; the structure here is BVH8".
#[derive(Clone, Debug, PartialEq)]
pub struct NotApplied {
    pub key: &'static str,
    pub why: String,
}

impl StructureParams {
    /// The parameters that do nothing for `self.kind` as the others stand (the grid's λ
    /// under a BVH, the buckets under the LBVH, the SIMD kernel of a BVH2): a front end
    /// that was told one of them says so instead of ignoring it.
    pub fn not_applied(&self) -> Vec<NotApplied> {
        use super::controls::controls_of;
        let kind = self.kind;
        let mut copy = *self;
        let bvh_family = kind.is_bvh() || kind.places_instances();
        let other = |whose: &str| format!("is {whose}; the structure here is {}", kind.title());
        let mut out = Vec::new();
        let mut add = |controls: Vec<super::controls::Control>, applies: bool, whose: &str| {
            for c in controls {
                let why = if !applies {
                    other(whose)
                } else if c.scope == Some("two-level") && !kind.places_instances() {
                    other("the two levels'")
                } else if c.scope == Some("wide") && !(kind.is_wide() || kind.places_instances()) {
                    other("BVH4's, BVH8's and the two levels'")
                } else if !c.enabled {
                    format!("is not used by the {} builder", self.bvh.strategy.label())
                } else {
                    continue;
                };
                out.push(NotApplied { key: c.key, why });
            }
        };
        add(controls_of(&mut copy.bvh), bvh_family, "the BVHs'");
        add(
            controls_of(&mut copy.kdtree),
            kind == AccelKind::KdTree,
            "the k-d tree's",
        );
        add(
            controls_of(&mut copy.grid),
            kind == AccelKind::Grid,
            "the grid's",
        );
        add(
            controls_of(&mut copy.octree),
            kind == AccelKind::Octree,
            "the octree's",
        );
        let mut fixed = |key, applies: bool, whose: &str| {
            if !applies {
                out.push(NotApplied {
                    key,
                    why: other(whose),
                });
            }
        };
        fixed("order", bvh_family, "the BVHs'");
        fixed(
            "mailbox",
            kind.is_spatial(),
            "the k-d tree's, the grid's and the octree's",
        );
        fixed(
            "simd",
            kind.is_wide() || kind.places_instances(),
            "BVH4's, BVH8's and the two levels'",
        );
        out
    }
}

/// What a cost parameter must be: C_isect a positive number (a free triangle test makes
/// every tree a single leaf), the other costs finite and 0 or more.
pub fn cost_rule(name: &str) -> &'static str {
    if name == "C_isect" {
        "a finite number above 0"
    } else {
        "a finite number, 0 or more"
    }
}

/// The CLI's parser of a whole-number parameter within `lo..=hi`: it names the flag (clap
/// adds it) and says plainly what is wrong, where the library's own check (for presets and
/// the app) names the quantity.
pub fn whole_in(lo: u32, hi: u32) -> impl Fn(&str) -> Result<u32, String> + Clone + Send + Sync {
    move |text| match text.parse::<u32>() {
        Ok(n) if (lo..=hi).contains(&n) => Ok(n),
        Ok(n) => Err(format!("{n} is not in {lo}..={hi}")),
        Err(_) if !text.is_empty() && text.bytes().all(|b| b.is_ascii_digit()) => {
            Err(format!("{text} is not in {lo}..={hi}"))
        }
        Err(_) => Err(format!("'{text}' is not a whole number")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Strategy;
    use crate::accel::kdtree::KdSplit;
    use crate::geometry::IntersectorKind;
    use clap::{Parser, ValueEnum};

    /// The hand-written lists of choices hold every variant: clap derives its own list from
    /// the enum, so a variant left out of `ALL` fails here.
    #[test]
    fn every_list_of_choices_holds_every_variant() {
        assert_eq!(AccelKind::ALL.as_slice(), AccelKind::value_variants());
        assert_eq!(Strategy::ALL.as_slice(), Strategy::value_variants());
        assert_eq!(
            TraversalOrder::ALL.as_slice(),
            TraversalOrder::value_variants()
        );
        assert_eq!(SimdLevel::ALL.as_slice(), SimdLevel::value_variants());
        assert_eq!(
            IntersectorKind::ALL.as_slice(),
            IntersectorKind::value_variants()
        );
        for kind in AccelKind::ALL {
            let name = kind.to_possible_value().unwrap();
            assert_eq!(name.get_name(), kind.label(), "the CLI's name is the label");
        }
        for level in SimdLevel::ALL {
            assert_eq!(level.to_possible_value().unwrap().get_name(), level.label());
        }
    }

    #[derive(Parser)]
    #[command(no_binary_name = true)]
    struct Cli {
        #[command(flatten)]
        params: StructureParams,
    }

    #[test]
    fn the_flags_and_the_keys_are_the_fields() {
        // Every flag has an id of its own (clap checks this only in debug builds).
        use clap::CommandFactory;
        Cli::command().debug_assert();
        let cli = Cli::try_parse_from(
            "--builder sbvh --buckets 24 --max-leaf 3 --rounds 2 --order naive --kd-bins 32 \
             --empty-bonus 0.5 --lambda 2 --octree-max-depth 9 --mailbox false --simd portable"
                .split_whitespace(),
        )
        .unwrap();
        let p = cli.params;
        assert_eq!(p.bvh.strategy, Strategy::Sbvh);
        assert_eq!((p.bvh.buckets, p.bvh.max_leaf_size), (24, 3));
        assert_eq!(p.bvh.treelet_rounds, 2);
        assert_eq!(p.order, TraversalOrder::Naive);
        assert_eq!(p.kdtree.split, KdSplit::Binned(32));
        assert_eq!(p.kdtree.empty_bonus, 0.5);
        assert_eq!(p.grid.lambda, 2.0);
        assert_eq!(p.octree.max_depth, 9);
        assert!(!p.mailbox);
        assert_eq!(p.simd, SimdLevel::Portable);
        // No flag: every default, as the library has it.
        let none = Cli::try_parse_from(std::iter::empty::<&str>())
            .unwrap()
            .params;
        assert_eq!(none, StructureParams::default());

        // The keys, as presets and saved settings spell them.
        let json = serde_json::to_value(p).unwrap();
        for (key, value) in [
            ("accel", serde_json::json!("Bvh")),
            ("strategy", serde_json::json!("Sbvh")),
            ("max_leaf_size", serde_json::json!(3)),
            ("treelet_rounds", serde_json::json!(2)),
            ("naive_order", serde_json::json!(true)),
            ("kd_bins", serde_json::json!(32)),
            ("kd_empty_bonus", serde_json::json!(0.5)),
            ("grid_lambda", serde_json::json!(2.0)),
            ("octree_max_depth", serde_json::json!(9)),
            ("mailbox", serde_json::json!(false)),
            ("simd", serde_json::json!("Portable")),
        ] {
            assert_eq!(json[key], value, "{key}");
        }
        assert_eq!(serde_json::from_value::<StructureParams>(json).unwrap(), p);
        // A missing key is its default, and a missing structure is the fastest here.
        let empty: StructureParams = serde_json::from_str("{}").unwrap();
        assert_eq!(
            empty,
            StructureParams {
                kind: AccelKind::fastest(),
                ..StructureParams::default()
            }
        );
    }

    /// Every preset key of a parameter struct has a control (the derive refuses a field
    /// without `#[param]`; this checks that the controls are the keys, in the same names),
    /// and each slider's range holds the default.
    #[test]
    fn every_parameter_has_a_control() {
        use crate::accel::controls::{Control, ControlVisitor, Controls, keys_of};
        fn keys_match(mut params: impl Controls + serde::Serialize + Copy) {
            let json = serde_json::to_value(params).unwrap();
            let mut keys: Vec<&str> = json
                .as_object()
                .unwrap()
                .keys()
                .map(|k| k.as_str())
                .collect();
            let mut controls = keys_of(&mut params);
            controls.dedup();
            keys.sort();
            controls.sort();
            assert_eq!(controls, keys);
        }
        keys_match(crate::accel::bvh::BuildParams::default());
        keys_match(crate::accel::kdtree::KdParams::default());
        keys_match(crate::accel::grid::GridParams::default());
        keys_match(crate::accel::octree::OctreeParams::default());

        struct InRange;
        impl ControlVisitor for InRange {
            fn whole(&mut self, c: &Control, v: &mut u32) {
                let (lo, hi) = c.range();
                assert!((lo..=hi).contains(&(*v as f64)), "{}: {v}", c.key);
            }
            fn real(&mut self, c: &Control, v: &mut f32) {
                let (lo, hi) = c.range();
                assert!((lo..=hi).contains(&(*v as f64)), "{}: {v}", c.key);
            }
            fn flag(&mut self, _: &Control, _: &mut bool) {}
            fn choice(&mut self, c: &Control, selected: &mut usize, options: &[&'static str]) {
                assert!(*selected < options.len(), "{}", c.key);
            }
        }
        let mut p = StructureParams::default();
        p.bvh.visit_controls(&mut InRange);
        p.kdtree.visit_controls(&mut InRange);
        p.grid.visit_controls(&mut InRange);
        p.octree.visit_controls(&mut InRange);
    }
}
