//! A parameter struct's fields as controls, for any front end.
//!
//! `#[derive(Controls)]` (the `bvhlab-derive` crate) reads each field's `#[param(...)]`
//! (label, slider range, log scale, when it applies) and its doc comment, and hands the
//! field to a [`ControlVisitor`]. The app's visitor draws an egui widget per control, so a
//! new parameter's slider follows from its field like its CLI flag (clap) and its preset
//! key (serde) do. The library itself draws nothing.

/// What a front end needs to show one parameter.
#[derive(Clone, Debug)]
pub struct Control {
    /// The preset key (the serde name), which is also its command-line flag's id.
    pub key: &'static str,
    /// The control's short label.
    pub label: &'static str,
    /// The field's doc comment: the hover text (and the CLI flag's help).
    pub help: &'static str,
    /// The slider's range; `None` for choices and toggles.
    pub min: Option<f64>,
    pub max: Option<f64>,
    /// A logarithmic slider (counts and thresholds spanning decades).
    pub log: bool,
    /// Whether the setting applies to the current choices (the builder, say); a front end
    /// shows it greyed out when it does not.
    pub enabled: bool,
    /// A control shown only in a context (e.g. "two-level"); `None` is always shown.
    pub scope: Option<&'static str>,
}

impl Control {
    /// The slider's range, which `#[param(range = ...)]` gives every number.
    pub fn range(&self) -> (f64, f64) {
        (self.min.unwrap_or(0.0), self.max.unwrap_or(1.0))
    }
}

/// A front end's way to show each kind of value.
pub trait ControlVisitor {
    /// A whole number (a count, a depth).
    fn whole(&mut self, control: &Control, value: &mut u32);
    /// A real number (a cost, a threshold).
    fn real(&mut self, control: &Control, value: &mut f32);
    /// A toggle.
    fn flag(&mut self, control: &Control, value: &mut bool);
    /// One of `options` (labels), `selected` by index.
    fn choice(&mut self, control: &Control, selected: &mut usize, options: &[&'static str]);
}

/// A parameter struct whose fields are controls (derived).
pub trait Controls {
    fn visit_controls(&mut self, visitor: &mut dyn ControlVisitor);
}

/// How a field's type is shown: numbers as sliders, enums as choices.
pub trait ControlValue {
    fn visit(&mut self, control: &Control, visitor: &mut dyn ControlVisitor);
}

impl ControlValue for u32 {
    fn visit(&mut self, control: &Control, visitor: &mut dyn ControlVisitor) {
        visitor.whole(control, self);
    }
}

impl ControlValue for f32 {
    fn visit(&mut self, control: &Control, visitor: &mut dyn ControlVisitor) {
        visitor.real(control, self);
    }
}

impl ControlValue for bool {
    fn visit(&mut self, control: &Control, visitor: &mut dyn ControlVisitor) {
        visitor.flag(control, self);
    }
}

/// An enum shown as a choice among `all`, each by its `label`.
pub fn choose<T: Copy + PartialEq>(
    value: &mut T,
    all: &[T],
    label: impl Fn(T) -> &'static str,
    control: &Control,
    visitor: &mut dyn ControlVisitor,
) {
    let options: Vec<&'static str> = all.iter().map(|&t| label(t)).collect();
    let mut selected = all.iter().position(|t| t == value).unwrap_or(0);
    visitor.choice(control, &mut selected, &options);
    if let Some(&chosen) = all.get(selected) {
        *value = chosen;
    }
}

/// The preset keys of a struct's controls, in order (for tests and listings).
pub fn keys_of(params: &mut impl Controls) -> Vec<&'static str> {
    struct Keys(Vec<&'static str>);
    impl ControlVisitor for Keys {
        fn whole(&mut self, c: &Control, _: &mut u32) {
            self.0.push(c.key);
        }
        fn real(&mut self, c: &Control, _: &mut f32) {
            self.0.push(c.key);
        }
        fn flag(&mut self, c: &Control, _: &mut bool) {
            self.0.push(c.key);
        }
        fn choice(&mut self, c: &Control, _: &mut usize, _: &[&'static str]) {
            self.0.push(c.key);
        }
    }
    let mut keys = Keys(Vec::new());
    params.visit_controls(&mut keys);
    keys.0
}

/// Every control of `params`, each with whether it applies as the struct's values stand
/// (its `when`).
pub fn controls_of(params: &mut impl Controls) -> Vec<Control> {
    struct All(Vec<Control>);
    impl ControlVisitor for All {
        fn whole(&mut self, c: &Control, _: &mut u32) {
            self.0.push(c.clone());
        }
        fn real(&mut self, c: &Control, _: &mut f32) {
            self.0.push(c.clone());
        }
        fn flag(&mut self, c: &Control, _: &mut bool) {
            self.0.push(c.clone());
        }
        fn choice(&mut self, c: &Control, _: &mut usize, _: &[&'static str]) {
            self.0.push(c.clone());
        }
    }
    let mut all = All(Vec::new());
    params.visit_controls(&mut all);
    all.0
}
