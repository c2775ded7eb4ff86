//! `#[derive(Controls)]`: a parameter struct's fields as controls.
//!
//! Each field carries `#[param(label = "…", range = LO..=HI, log, when = Self::uses_it,
//! scope = "two-level")]` (only `label` is required) or `#[param(skip)]`; fields with
//! `#[serde(skip)]` are internal and skipped. The field's doc comment is the control's
//! hover text (the same text is the CLI flag's help), and its preset key is the serde name.
//! A field with neither attribute is a compile error, so no parameter goes without a
//! control. The generated `impl crate::accel::controls::Controls` hands each field to a
//! `ControlVisitor`; the app's visitor draws egui widgets, the tests' visitor lists keys.

use proc_macro::TokenStream;
use proc_macro2::TokenStream as Tokens;
use quote::quote;
use syn::{Data, DeriveInput, Expr, Fields, LitStr, parse_macro_input, spanned::Spanned};

#[proc_macro_derive(Controls, attributes(param))]
pub fn derive_controls(input: TokenStream) -> TokenStream {
    let input = parse_macro_input!(input as DeriveInput);
    match controls(&input) {
        Ok(tokens) => tokens.into(),
        Err(error) => error.to_compile_error().into(),
    }
}

/// What `#[param(...)]` says of one field.
#[derive(Default)]
struct Param {
    skip: bool,
    label: Option<LitStr>,
    range: Option<(Expr, Expr)>,
    log: bool,
    when: Option<Expr>,
    scope: Option<LitStr>,
}

fn controls(input: &DeriveInput) -> syn::Result<Tokens> {
    let Data::Struct(data) = &input.data else {
        return Err(syn::Error::new(
            input.span(),
            "Controls is derived for structs",
        ));
    };
    let Fields::Named(fields) = &data.fields else {
        return Err(syn::Error::new(input.span(), "Controls needs named fields"));
    };
    let mut visits = Vec::new();
    for field in &fields.named {
        let ident = field.ident.as_ref().expect("named field");
        let param = param_of(field)?;
        let (serde_skip, serde_name) = serde_of(field)?;
        if param.skip || serde_skip {
            continue;
        }
        let Some(label) = param.label else {
            return Err(syn::Error::new(
                field.span(),
                "a parameter needs its control: #[param(label = \"…\")], or #[param(skip)]",
            ));
        };
        let key = serde_name.unwrap_or_else(|| ident.to_string());
        let help = doc_of(field);
        let (min, max) = match param.range {
            Some((lo, hi)) => (quote!(Some((#lo) as f64)), quote!(Some((#hi) as f64))),
            None => (quote!(None), quote!(None)),
        };
        let log = param.log;
        let enabled = match param.when {
            Some(when) => quote!((#when)(self)),
            None => quote!(true),
        };
        let scope = match param.scope {
            Some(scope) => quote!(Some(#scope)),
            None => quote!(None),
        };
        // The control is made before the field is borrowed: `when` reads the whole struct.
        visits.push(quote! {
            let control = crate::accel::controls::Control {
                key: #key,
                label: #label,
                help: #help,
                min: #min,
                max: #max,
                log: #log,
                enabled: #enabled,
                scope: #scope,
            };
            crate::accel::controls::ControlValue::visit(&mut self.#ident, &control, visitor);
        });
    }
    let name = &input.ident;
    Ok(quote! {
        impl crate::accel::controls::Controls for #name {
            fn visit_controls(&mut self, visitor: &mut dyn crate::accel::controls::ControlVisitor) {
                #(#visits)*
            }
        }
    })
}

fn param_of(field: &syn::Field) -> syn::Result<Param> {
    let mut param = Param::default();
    for attr in field.attrs.iter().filter(|a| a.path().is_ident("param")) {
        attr.parse_nested_meta(|meta| {
            if meta.path.is_ident("skip") {
                param.skip = true;
            } else if meta.path.is_ident("log") {
                param.log = true;
            } else if meta.path.is_ident("label") {
                param.label = Some(meta.value()?.parse()?);
            } else if meta.path.is_ident("scope") {
                param.scope = Some(meta.value()?.parse()?);
            } else if meta.path.is_ident("when") {
                param.when = Some(meta.value()?.parse()?);
            } else if meta.path.is_ident("range") {
                let range: syn::ExprRange = meta.value()?.parse()?;
                let (Some(lo), Some(hi), syn::RangeLimits::Closed(_)) =
                    (range.start, range.end, range.limits)
                else {
                    return Err(meta.error("range = LO..=HI"));
                };
                param.range = Some((*lo, *hi));
            } else {
                return Err(meta.error("param takes label, range, log, when, scope or skip"));
            }
            Ok(())
        })?;
    }
    Ok(param)
}

/// `#[serde(skip)]` and `#[serde(rename = "…")]`: the field's preset key.
fn serde_of(field: &syn::Field) -> syn::Result<(bool, Option<String>)> {
    let (mut skip, mut rename) = (false, None);
    for attr in field.attrs.iter().filter(|a| a.path().is_ident("serde")) {
        attr.parse_nested_meta(|meta| {
            if meta.path.is_ident("skip") {
                skip = true;
            } else if meta.path.is_ident("rename") {
                rename = Some(meta.value()?.parse::<LitStr>()?.value());
            } else if meta.input.peek(syn::Token![=]) {
                // Other keys (`with`, `default`…) are serde's alone.
                meta.value()?.parse::<Expr>()?;
            }
            Ok(())
        })?;
    }
    Ok((skip, rename))
}

/// The field's doc comment, its lines joined: the control's hover text.
fn doc_of(field: &syn::Field) -> String {
    let lines: Vec<String> = field
        .attrs
        .iter()
        .filter(|a| a.path().is_ident("doc"))
        .filter_map(|a| match &a.meta {
            syn::Meta::NameValue(nv) => match &nv.value {
                Expr::Lit(syn::ExprLit {
                    lit: syn::Lit::Str(s),
                    ..
                }) => Some(s.value().trim().to_string()),
                _ => None,
            },
            _ => None,
        })
        .collect();
    lines.join(" ")
}
