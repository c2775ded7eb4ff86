//! The crack view for the app: the view's crossings (exact rays at every shared edge and
//! closed vertex fan in view, `render::cracks`) made once per view, offset and tree, and
//! judged by all three ray–triangle tests, so switching the test is a recolouring.

use super::messages::{CracksRequest, CracksShown, Reply};
use super::state::State;
use crate::geometry::IntersectorKind;
use crate::render::cracks::{CrackSetup, CrackView, SEED};
use std::sync::Arc;

/// What a crack view was made for: the request but its test, and the scene and tree.
#[derive(Clone, Debug, PartialEq)]
pub(in crate::app) struct CrackKey {
    request: CracksRequest,
    version: u64,
}

impl State {
    /// Judges the request's crossings with every test and sends the chosen test's leaks.
    pub(in crate::app) fn cracks(&mut self, request: CracksRequest) {
        let shown = self.crack_study(&request).map(Arc::new);
        self.reply(Reply::Cracks(request, shown));
    }

    fn crack_study(&mut self, request: &CracksRequest) -> Result<CracksShown, String> {
        let Some(scene) = &self.scene else {
            return Err("there is no scene yet".into());
        };
        let key = CrackKey {
            request: CracksRequest {
                intersector: IntersectorKind::default(),
                ..request.clone()
            },
            version: self.version,
        };
        let view = match &self.crack_view {
            Some((k, v)) if *k == key => v.clone(),
            _ => {
                let settings = super::frames::view_settings(
                    scene,
                    request.camera,
                    request.width,
                    request.height,
                );
                let setup = CrackSetup::new(&settings, request.offset);
                let view =
                    CrackView::new(scene, &setup, &self.params, SEED).map_err(|e| e.to_string())?;
                let view = Arc::new(view);
                self.crack_view = Some((key, view.clone()));
                view
            }
        };
        let judged = IntersectorKind::ALL.map(|kind| view.classify(kind));
        let chosen = judged
            .iter()
            .find(|c| c.kind == request.intersector)
            .unwrap_or(&judged[0]);
        Ok(CracksShown {
            markers: view.markers(chosen),
            reports: judged.map(|c| (c.kind, c.report)),
            rays: view.crossings.len(),
        })
    }
}
