//! Reports the component values the renderer cannot use as they are.
//!
//! The renderer never draws a NaN, an out-of-range or an inconsistent value: it draws the
//! cleaned copy of each component and of the world ([`CloudLayer::sanitize`],
//! [`VolumetricClouds::sanitize`], [`CloudWorld::sanitize`], whose docs list the rule for every
//! field). This module tells the user when that happens: when a component or the world changes,
//! each field whose cleaned value differs from the one given is reported with one `warn!` that
//! names the entity (for a component), the field, the value given and the value used. A field is
//! reported once while it stays wrong, and again if it goes wrong again after being fixed.

use bevy::{
    platform::collections::{HashMap, HashSet},
    prelude::*,
    reflect::{PartialReflect, structs::Struct},
};

use crate::{
    layers::CloudLayer, render::VolumetricClouds, sky::stars::StarField, world::CloudWorld,
};

/// A component or resource whose values the renderer cleans before use.
pub(crate) trait Sanitize: Struct + Clone {
    /// The component's type name in messages.
    const TYPE_NAME: &'static str;
    /// The copy the renderer draws.
    fn sanitized_copy(&self) -> Self;
}

impl Sanitize for CloudLayer {
    const TYPE_NAME: &'static str = "CloudLayer";
    fn sanitized_copy(&self) -> Self {
        self.sanitized()
    }
}

impl Sanitize for VolumetricClouds {
    const TYPE_NAME: &'static str = "VolumetricClouds";
    fn sanitized_copy(&self) -> Self {
        self.sanitized()
    }
}

impl Sanitize for StarField {
    const TYPE_NAME: &'static str = "StarField";
    fn sanitized_copy(&self) -> Self {
        self.sanitized()
    }
}

impl Sanitize for CloudWorld {
    const TYPE_NAME: &'static str = "CloudWorld";
    fn sanitized_copy(&self) -> Self {
        self.sanitized()
    }
}

/// One field that the renderer uses with another value than the one given.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Correction {
    /// The field's name.
    pub field: String,
    /// The value given, as `Debug` prints it.
    pub given: String,
    /// The value the renderer uses instead.
    pub used: String,
}

/// Whether two reflected values are equal, with NaN equal to NaN (a field whose NaN is a
/// documented value, kept by the cleaning, is not a correction).
fn same_value(a: &dyn PartialReflect, b: &dyn PartialReflect) -> bool {
    if let (Some(a), Some(b)) = (a.try_downcast_ref::<f32>(), b.try_downcast_ref::<f32>()) {
        return a == b || (a.is_nan() && b.is_nan());
    }
    a.reflect_partial_eq(b).unwrap_or(false)
}

/// The fields of `value` that its cleaned copy changes, in declaration order.
pub(crate) fn corrections<C: Sanitize>(value: &C) -> Vec<Correction> {
    let clean = value.sanitized_copy();
    (0..value.field_len())
        .filter_map(|i| {
            let (given, used) = (value.field_at(i)?, clean.field_at(i)?);
            let field = value.name_at(i)?.to_owned();
            (!same_value(given, used)).then(|| Correction {
                field,
                given: format!("{given:?}"),
                used: format!("{used:?}"),
            })
        })
        .collect()
}

/// The fields of `found` not reported yet for one entity, which `reported` (the fields reported
/// so far) then holds; fields no longer in `found` are forgotten, so they are reported again if
/// they go wrong again.
fn unreported(reported: &mut HashSet<String>, found: Vec<Correction>) -> Vec<Correction> {
    reported.retain(|field| found.iter().any(|c| c.field == *field));
    found
        .into_iter()
        .filter(|correction| reported.insert(correction.field.clone()))
        .collect()
}

/// Warns once per entity and field about the values of a changed `C` that the renderer
/// replaces; see the [module docs](self).
pub(crate) fn report_corrections<C: Sanitize + Component>(
    changed: Query<(Entity, &C), Changed<C>>,
    mut removed: RemovedComponents<C>,
    mut reported: Local<HashMap<Entity, HashSet<String>>>,
) {
    for entity in removed.read() {
        reported.remove(&entity);
    }
    for (entity, value) in &changed {
        let fields = reported.entry(entity).or_default();
        for correction in unreported(fields, corrections(value)) {
            warn!(
                "{}::{} of entity {entity} is {}, which cannot be drawn; using {} \
                 (see {}::sanitize)",
                C::TYPE_NAME,
                correction.field,
                correction.given,
                correction.used,
                C::TYPE_NAME,
            );
        }
        if fields.is_empty() {
            reported.remove(&entity);
        }
    }
}

/// Warns once per field about the values of a changed resource (a [`CloudWorld`], a
/// [`StarField`]) that the renderer replaces.
fn report_resource_corrections<R: Sanitize + Resource>(
    resource: Option<Res<R>>,
    mut reported: Local<HashSet<String>>,
) {
    let Some(resource) = resource.filter(|resource| resource.is_changed()) else {
        return;
    };
    for correction in unreported(&mut reported, corrections(&*resource)) {
        warn!(
            "{}::{} is {}, which cannot be drawn; using {} (see {}::sanitize)",
            R::TYPE_NAME,
            correction.field,
            correction.given,
            correction.used,
            R::TYPE_NAME,
        );
    }
}

/// Adds the reports for [`CloudLayer`], [`VolumetricClouds`], [`CloudWorld`] and
/// [`StarField`].
pub(crate) fn plugin(app: &mut App) {
    app.add_systems(
        PostUpdate,
        (
            report_corrections::<CloudLayer>,
            report_corrections::<VolumetricClouds>,
            report_resource_corrections::<CloudWorld>,
            report_resource_corrections::<StarField>,
        ),
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layers::CloudKind;

    fn fields(list: &[Correction]) -> Vec<&str> {
        list.iter().map(|c| c.field.as_str()).collect()
    }

    #[test]
    fn clean_components_have_no_corrections() {
        for kind in CloudKind::ALL {
            assert!(corrections(&CloudLayer::new(kind)).is_empty(), "{kind}");
        }
        for preset in [
            VolumetricClouds::LOW,
            VolumetricClouds::MEDIUM,
            VolumetricClouds::HIGH,
            VolumetricClouds::ULTRA,
        ] {
            assert!(corrections(&preset).is_empty(), "{:?}", preset.quality());
        }
        assert!(corrections(&CloudWorld::default()).is_empty());
    }

    #[test]
    fn each_bad_field_is_named_with_the_value_given_and_used() {
        let layer = CloudLayer {
            coverage: f32::NAN,
            density: -1.0,
            ..CloudLayer::new(CloudKind::Stratus)
        };
        let found = corrections(&layer);
        assert_eq!(fields(&found), ["coverage", "density"]);
        assert_eq!(found[0].given, "NaN");
        assert_eq!(
            found[0].used,
            format!("{:?}", CloudKind::Stratus.defaults().coverage)
        );
        assert_eq!(
            (found[1].given.as_str(), found[1].used.as_str()),
            ("-1.0", "0.0")
        );
    }

    #[test]
    fn a_base_above_the_top_reports_both() {
        let layer = CloudLayer {
            base_m: 3000.0,
            top_m: 1000.0,
            ..default()
        };
        assert_eq!(fields(&corrections(&layer)), ["base_m", "top_m"]);
    }

    #[test]
    fn a_documented_nan_is_not_a_correction() {
        // NaN light steps per footprint means "no limit".
        let clouds = VolumetricClouds {
            light_steps_per_footprint: f32::NAN,
            ..default()
        };
        assert!(corrections(&clouds).is_empty());
    }

    #[test]
    fn a_field_is_reported_once_while_it_stays_wrong_and_again_after_a_fix() {
        let mut reported = HashSet::new();
        let mut layer = CloudLayer {
            coverage: 2.0,
            ..default()
        };
        let first = unreported(&mut reported, corrections(&layer));
        assert_eq!(fields(&first), ["coverage"]);
        // Another field goes wrong: only that one is new.
        layer.density = f32::INFINITY;
        let second = unreported(&mut reported, corrections(&layer));
        assert_eq!(fields(&second), ["density"]);
        // Unchanged: nothing new.
        assert!(unreported(&mut reported, corrections(&layer)).is_empty());
        // Fixed, then wrong again: reported again.
        layer.coverage = 0.5;
        layer.density = 0.05;
        assert!(unreported(&mut reported, corrections(&layer)).is_empty());
        assert!(reported.is_empty());
        layer.coverage = -1.0;
        assert_eq!(
            fields(&unreported(&mut reported, corrections(&layer))),
            ["coverage"]
        );
    }

    #[test]
    fn the_system_runs_on_changed_components() {
        // The system itself, in an app: it must accept both component types and a despawn.
        let mut app = App::new();
        app.add_plugins(plugin);
        let layer = app
            .world_mut()
            .spawn(CloudLayer {
                top_m: f32::NAN,
                ..default()
            })
            .id();
        app.world_mut().spawn(VolumetricClouds {
            primary_steps: 0,
            ..default()
        });
        app.insert_resource(CloudWorld {
            planet_radius_m: f32::NAN,
            ..default()
        });
        app.update();
        app.world_mut().despawn(layer);
        app.update();
    }
}
