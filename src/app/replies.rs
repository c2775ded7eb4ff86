//! What the app does with the worker's replies: a loaded scene, a built or refitted
//! structure, a frame to show, a replay, an error to say.

use super::*;
use eframe::egui;
use orbit::Orbit;
use std::sync::Arc;
use worker::{Command, Reply};

impl BvhLabApp {
    /// Handles everything the worker has said since the last frame (public for the UI
    /// tests, which hand it replies in a chosen order).
    pub fn handle_replies(&mut self, ctx: &egui::Context, replies: Vec<Reply>) {
        for r in replies {
            match r {
                Reply::Loaded { spec, scene } => {
                    // A scene that does not store its triangles (the island) can only be
                    // traced through its two levels.
                    if !scene.is_flattened() {
                        self.settings.structure.kind = crate::accel::AccelKind::TwoLevel;
                    }
                    self.orbit = Orbit::from_camera(&scene.camera());
                    if std::path::Path::new(&spec).exists() && scene::is_file_spec(&spec) {
                        self.settings.add_recent(&spec);
                    }
                    self.settings.scene = spec;
                    self.scene_rows = scene
                        .instancing_rows()
                        .into_iter()
                        .map(|(k, v)| (format!("scene {k}"), v))
                        .collect();
                    self.scene = Some(scene);
                    self.load_error = None;
                    self.warnings_dismissed = false;
                    self.selection = None;
                    self.selected_object = None;
                    self.moved_transforms.clear();
                    self.walk = None;
                    self.instance_outline = None;
                    self.leaf_instances = Arc::default();
                    self.replay = None;
                    self.building = true;
                    self.apply_pending_view();
                }
                Reply::LoadFailed { error, .. } => self.load_error = Some(error),
                Reply::Built {
                    report,
                    bvh_report,
                    outline,
                    leaf_instances,
                    sah,
                } => {
                    self.sah_prediction = sah;
                    self.sah_history = bvh_report.iter().map(|r| r.tree.sah_cost).collect();
                    // The selected instance's BLAS comes again (`InstanceSelected`) if the
                    // new structure has it.
                    self.instance_outline = None;
                    self.leaf_instances = leaf_instances;
                    // A levels screenshot names a depth the tree must have (below an
                    // instance's top level, its BLAS's levels follow: not known here).
                    if let Some(p) = self.screenshot.as_mut()
                        && let Some(level) = p.level
                        && p.instance.is_none()
                        && level > outline.max_depth()
                    {
                        p.fail(format!(
                            "there is no level {level}: the tree's levels are 0 to {}",
                            outline.max_depth()
                        ));
                    }
                    self.settings.level = self.settings.level.min(outline.max_depth());
                    self.walk = self.walk.filter(|&w| (w as usize) < outline.nodes.len());
                    // A screenshot of the tree walk opens it at the node it names.
                    if let Some(node) = self.screenshot.as_ref().and_then(|p| p.walk) {
                        let nodes = outline.nodes.len();
                        if node as usize >= nodes {
                            let why = format!(
                                "there is no node {node} to walk from: the tree has {nodes} \
                                 nodes, 0 to {}",
                                nodes.saturating_sub(1)
                            );
                            if let Some(p) = self.screenshot.as_mut() {
                                p.fail(why);
                            }
                        }
                        self.walk = Some(node.min(nodes.saturating_sub(1) as u32));
                    }
                    // A screenshot of an instance's BLAS selects it once the levels exist.
                    if let Some(i) = self.screenshot.as_ref().and_then(|p| p.instance) {
                        self.worker.send(Command::SelectInstance(Some(i)));
                    }
                    self.outline = outline;
                    self.apply_pending_structure();
                    // The replayed steps name nodes of the old structure.
                    self.replay = None;
                    self.report = Some(*report);
                    self.bvh_report = bvh_report.map(|b| *b);
                    self.build_error = None;
                    self.building = false;
                }
                Reply::BuildFailed(e) => {
                    self.build_error = Some(e);
                    self.building = false;
                }
                Reply::Refitted {
                    sah_before,
                    sah_after,
                    refit_time,
                    undo,
                } => {
                    // A wide BVH's build report has no SAH cost: its first refit gives it.
                    if self.sah_history.is_empty() {
                        self.sah_history.push(sah_before);
                    }
                    // An undo takes back its move's point; the build's stays.
                    if !undo {
                        self.sah_history.push(sah_after);
                    } else if self.sah_history.len() > 1 {
                        self.sah_history.pop();
                    }
                    self.last_refit = Some(refit_time);
                    // The refitted tree's EPO follows.
                    if let Some(p) = &mut self.sah_prediction {
                        p.epo = None;
                    }
                    self.maybe_auto_rebuild();
                }
                Reply::Outline(outline) => self.outline = outline,
                Reply::RebuiltAfterMove {
                    rebuild_time,
                    bvh_refit_time,
                    outline,
                } => {
                    self.last_rebuild = Some((rebuild_time, bvh_refit_time));
                    self.settings.level = self.settings.level.min(outline.max_depth());
                    self.walk = self.walk.filter(|&w| (w as usize) < outline.nodes.len());
                    self.outline = outline;
                }
                Reply::InstanceMoved {
                    refit_time,
                    flat_refit_time,
                    object,
                    transform,
                } => {
                    self.last_instance_move = Some((refit_time, flat_refit_time));
                    self.moved_transforms.insert(object, transform);
                }
                Reply::Frame(shown) => {
                    if let Some(t) = self.move_sent.take() {
                        self.drag_latency = Some(t.elapsed());
                    }
                    let [w, h] = [shown.job.width as usize, shown.job.height as usize];
                    let image = egui::ColorImage::from_rgba_unmultiplied([w, h], &shown.rgba);
                    match &mut self.texture {
                        Some(t) => t.set(image, egui::TextureOptions::LINEAR),
                        None => {
                            self.texture =
                                Some(ctx.load_texture("frame", image, egui::TextureOptions::LINEAR))
                        }
                    }
                    if !shown.job.preview {
                        self.full_summary = Some(shown.frame.summary.clone());
                        self.compared = shown.compared.clone();
                    }
                    self.shown = Some(shown);
                }
                Reply::Counted { job, frame } => {
                    // The counts of the full frame on screen: same hits, same image.
                    if let Some(shown) = self.shown.as_mut().filter(|s| s.job == job) {
                        self.full_summary = Some(frame.summary.clone());
                        Arc::make_mut(shown).frame = frame;
                    }
                }
                Reply::Snapshot(scene) => self.snapshot = Some(scene),
                Reply::InstanceSelected(outlined) => self.instance_selected(outlined),
                Reply::Replayed(Ok(replay)) => {
                    let mut view = replay::ReplayView::new(replay);
                    if let Some(r) = self.screenshot.as_ref().and_then(|p| p.replay) {
                        let stops = view.replay.stops();
                        if r.visit != usize::MAX && r.visit > stops {
                            let why = format!(
                                "there is no visit {}: the ray visits {stops} nodes",
                                r.visit
                            );
                            if let Some(p) = self.screenshot.as_mut() {
                                p.fail(why);
                            }
                        }
                        view.stop = r.visit.saturating_sub(1).min(stops - 1);
                    }
                    self.replay = Some(view);
                    self.replay_error = None;
                }
                Reply::Replayed(Err(e)) => self.replay_error = Some(e),
                Reply::Epo(epo) => {
                    if let Some(p) = &mut self.sah_prediction {
                        p.epo = Some(epo);
                    }
                }
                Reply::BlasEpo { instance, epo } => {
                    if let Some(b) = &mut self.blas_costs {
                        b.set_epo(instance, epo);
                    }
                }
                Reply::NodeVisits(request, visits) => {
                    if self.visits_asked.as_ref() == Some(&request) {
                        self.visits_asked = None;
                    }
                    // Counted over the outline the worker had; kept for the outline shown
                    // now, which the worker's replies keep in step with it.
                    if let Some(v) = visits.filter(|v| v.per_node.len() == self.outline.nodes.len())
                    {
                        let outline = Arc::as_ptr(&self.outline) as usize;
                        self.node_visits = Some((outline, request, v));
                    }
                }
                Reply::Cracks(request, shown) => {
                    if self.cracks_asked.as_ref() == Some(&request) {
                        self.cracks_asked = None;
                    }
                    self.cracks = Some((request, shown));
                }
                Reply::Idle(_) | Reply::Prefetched(_) => {}
            }
        }
    }
}
