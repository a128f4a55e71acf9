//! The checks of a scene's materials: contact laws, restitution, friction, rolling resistance,
//! liquid, cohesion, and the constitutive law of a deformable material.

use super::model::*;
use super::spec::*;
use super::violation::Checker;
use crate::constitutive::LawSpec;

/// Checks a deformable material's constitutive law (every bad parameter named).
fn check_deformable(c: &mut Checker, p: &str, d: &DeformableSpec) -> LawSpec {
    let q = format!("{p}.deformable");
    let poisson = |c: &mut Checker, nu: f64| {
        if !(nu.is_finite() && nu > -1.0 && nu < 0.5) {
            c.fail(format!("{q}.poisson_ratio"), format!("must be > -1 and < 0.5, got {nu}"));
        }
    };
    match *d {
        DeformableSpec::LinearElastic { young_modulus, poisson_ratio } => {
            c.positive(&format!("{q}.young_modulus"), young_modulus);
            poisson(c, poisson_ratio);
            LawSpec::LinearElastic { young: young_modulus, poisson: poisson_ratio }
        }
        DeformableSpec::NeoHookean { shear_modulus, lambda } => {
            c.positive(&format!("{q}.shear_modulus"), shear_modulus);
            c.non_negative(&format!("{q}.lambda"), lambda);
            LawSpec::NeoHookean { shear_modulus, lambda }
        }
        DeformableSpec::Elastoplastic { young_modulus, poisson_ratio, yield_stress, hardening } => {
            c.positive(&format!("{q}.young_modulus"), young_modulus);
            poisson(c, poisson_ratio);
            c.positive(&format!("{q}.yield_stress"), yield_stress);
            c.non_negative(&format!("{q}.hardening"), hardening);
            LawSpec::Elastoplastic { young: young_modulus, poisson: poisson_ratio, yield_stress, hardening }
        }
    }
}

/// Checks a material. Its restitution may be 0 (a perfectly plastic impact, which contact
/// dynamics models; DEM, whose restitution is a damping ratio, refuses it).
pub(super) fn check_material(c: &mut Checker, name: &str, m: &MaterialSpec) -> Material {
    let p = format!("materials.{name}");
    c.positive(&format!("{p}.density"), m.density);
    if let Some(d) = &m.deformable {
        return deformable_material(c, name, &p, m, d);
    }
    let law = check_contact_law(c, &p, m.contact.as_ref());
    let restitution = m.restitution.unwrap_or_else(|| {
        c.fail(format!("{p}.restitution"), "required, unless the material is deformable");
        1.0
    });
    if !(restitution.is_finite() && (0.0..=1.0).contains(&restitution)) {
        c.fail(format!("{p}.restitution"), format!("must be >= 0 and <= 1, got {restitution}"));
    }
    c.non_negative(&format!("{p}.friction"), m.friction);
    let ratio = m.tangential_damping_ratio.unwrap_or(0.5);
    c.non_negative(&format!("{p}.tangential_damping_ratio"), ratio);
    let limit_damping = m.limit_damping.unwrap_or(true);
    let rolling = m.rolling.as_ref().map(|r| {
        c.non_negative(&format!("{p}.rolling.stiffness"), r.stiffness);
        c.non_negative(&format!("{p}.rolling.friction"), r.friction);
        Rolling { stiffness: r.stiffness, friction: r.friction }
    });
    let liquid = m.liquid.as_ref().map(|l| check_liquid(c, &p, l));
    let cohesion = m.cohesion.as_ref().map(|k| {
        c.positive(&format!("{p}.cohesion.force"), k.force);
        c.non_negative(&format!("{p}.cohesion.distance"), k.distance);
        Cohesion { force: k.force, distance: k.distance }
    });
    Material {
        name: name.to_string(),
        density: m.density,
        law,
        restitution,
        friction: m.friction,
        tangential_damping_ratio: ratio,
        limit_damping,
        rolling,
        liquid,
        cohesion,
        deformable: None,
    }
}

/// Checks a deformable material: its constitutive law, and none of the point-contact fields.
fn deformable_material(c: &mut Checker, name: &str, p: &str, m: &MaterialSpec, d: &DeformableSpec) -> Material {
    let deformable = check_deformable(c, p, d);
    for (given, key) in [
        (m.contact.is_some(), "contact"),
        (m.restitution.is_some(), "restitution"),
        (m.rolling.is_some(), "rolling"),
        (m.liquid.is_some(), "liquid"),
        (m.cohesion.is_some(), "cohesion"),
        (m.tangential_damping_ratio.is_some(), "tangential_damping_ratio"),
        (m.limit_damping.is_some(), "limit_damping"),
    ] {
        if given {
            c.fail(format!("{p}.{key}"), "not for a deformable material: its grains touch through their constitutive law (leave it out)");
        }
    }
    c.non_negative(&format!("{p}.friction"), m.friction);
    let (young, poisson) = deformable.young_poisson();
    Material {
        name: name.to_string(),
        density: m.density,
        law: ElasticLaw::HertzMindlin { young, poisson },
        restitution: 0.0,
        friction: m.friction,
        tangential_damping_ratio: 0.0,
        limit_damping: true,
        rolling: None,
        liquid: None,
        cohesion: None,
        deformable: Some(deformable),
    }
}

/// Checks a point-contact material's elastic contact law (linear or Hertz–Mindlin).
fn check_contact_law(c: &mut Checker, p: &str, contact: Option<&ContactLawSpec>) -> ElasticLaw {
    match contact {
        Some(&ContactLawSpec::Linear { k_n, k_t }) => {
            c.positive(&format!("{p}.contact.k_n"), k_n);
            let k_t = k_t.unwrap_or(2.0 / 7.0 * k_n);
            c.non_negative(&format!("{p}.contact.k_t"), k_t);
            ElasticLaw::Linear { k_n, k_t }
        }
        Some(&ContactLawSpec::HertzMindlin { young_modulus, poisson_ratio }) => {
            c.positive(&format!("{p}.contact.young_modulus"), young_modulus);
            if !(poisson_ratio.is_finite() && poisson_ratio > -1.0 && poisson_ratio < 0.5) {
                c.fail(format!("{p}.contact.poisson_ratio"), format!("must be > -1 and < 0.5, got {poisson_ratio}"));
            }
            ElasticLaw::HertzMindlin { young: young_modulus, poisson: poisson_ratio }
        }
        None => {
            c.fail(format!("{p}.contact"), "required (the elastic contact law), unless the material is deformable");
            ElasticLaw::Linear { k_n: 1.0, k_t: 0.0 }
        }
    }
}

/// Checks a material's liquid: its bridges, and the roughness that bounds lubrication.
fn check_liquid(c: &mut Checker, p: &str, l: &LiquidSpec) -> Liquid {
    let q = format!("{p}.liquid");
    c.positive(&format!("{q}.surface_tension"), l.surface_tension);
    c.within(&format!("{q}.contact_angle"), l.contact_angle, 0.0, std::f64::consts::FRAC_PI_2 - 1e-9);
    c.positive(&format!("{q}.bridge_volume"), l.bridge_volume);
    c.non_negative(&format!("{q}.viscosity"), l.viscosity);
    let roughness = match l.roughness {
        Some(h) => {
            c.positive(&format!("{q}.roughness"), h);
            h
        }
        None if l.viscosity > 0.0 => {
            c.fail(format!("{q}.roughness"), "required when viscosity > 0 (it bounds the lubrication force)");
            0.0
        }
        None => 0.0,
    };
    Liquid {
        surface_tension: l.surface_tension,
        contact_angle: l.contact_angle,
        bridge_volume: l.bridge_volume,
        viscosity: l.viscosity,
        roughness,
    }
}

/// Checks the scene's materials, each by [`check_material`], and that those with a contact law
/// share one (linear or Hertz–Mindlin).
pub(super) fn check_materials(c: &mut Checker, spec: &SceneSpec) -> Vec<Material> {
    if spec.materials.is_empty() {
        c.fail("materials", "must define at least one material");
    }
    let materials: Vec<Material> = spec.materials.iter().map(|(name, m)| check_material(c, name, m)).collect();
    let hertz = |m: &Material| matches!(m.law, ElasticLaw::HertzMindlin { .. });
    let contact_materials: Vec<&Material> = materials.iter().filter(|m| m.deformable.is_none()).collect();
    if let Some(first) = contact_materials.first() {
        for m in &contact_materials[1..] {
            if hertz(m) != hertz(first) {
                c.fail(
                    format!("materials.{}.contact.law", m.name),
                    format!("all materials must use the same contact law ('{}' uses another one)", first.name),
                );
            }
        }
    }
    materials
}
