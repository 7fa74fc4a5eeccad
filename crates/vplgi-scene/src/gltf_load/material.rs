//! A glTF material's surface (`vplgi_shared::bsdf::Surface`) from its metallic-roughness factors,
//! `KHR_materials_transmission`, `KHR_materials_ior` and `KHR_materials_volume`, by the table of
//! `vplgi_shared::bsdf`: metallic 0 is diffuse, metallic 1 a mirror (roughness 0) or a GGX metal
//! of α = roughness², anything between their blend, and transmission glass: solid with a volume,
//! a thin pane without.

use vplgi_shared::bsdf::Surface;

/// The smallest GGX α of a metal blended over diffuse: the blend has no mirror lobe, and below
/// this its GGX peak overflows f32.
pub(super) const MIN_BLEND_ALPHA: f32 = 1e-4;

/// What glTF says of a material's scattering, as numbers (its defaults filled in).
pub(super) struct Factors {
    pub metallic: f32,
    pub roughness: f32,
    pub transmission: f32,
    pub ior: f32,
    /// `KHR_materials_volume`'s thickness, when the extension is present.
    pub thickness: Option<f32>,
}

/// The surface, with what it could not represent (warnings); an error says which factor is
/// invalid.
pub(super) fn surface(f: &Factors) -> Result<(Surface, Vec<String>), String> {
    for (name, v) in [
        ("metallicFactor", f.metallic),
        ("roughnessFactor", f.roughness),
        ("transmissionFactor", f.transmission),
    ] {
        if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
            return Err(format!("{name} {v} is outside [0, 1]"));
        }
    }
    if !(f.ior.is_finite() && f.ior > 0.0) {
        return Err(format!("the index of refraction {} is not a finite number above 0", f.ior));
    }
    let mut warnings = Vec::new();
    if f.transmission > 0.0 {
        if f.transmission < 1.0 {
            warnings.push(format!(
                "transmission {} is taken as 1 (vplgi has no partly transmissive surface)",
                f.transmission
            ));
        }
        if f.roughness > 0.0 {
            warnings.push(format!(
                "roughness {} of a transmissive surface is taken as 0 (smooth glass)",
                f.roughness
            ));
        }
        let eta = f.ior;
        let solid = f.thickness.is_some_and(|t| t > 0.0);
        return Ok((
            if solid { Surface::Dielectric { eta } } else { Surface::ThinDielectric { eta } },
            warnings,
        ));
    }
    let alpha = f.roughness * f.roughness;
    let s = if f.metallic == 0.0 {
        Surface::Diffuse
    } else if f.metallic == 1.0 && alpha == 0.0 {
        Surface::Mirror
    } else if f.metallic == 1.0 {
        Surface::RoughConductor { alpha }
    } else {
        if alpha < MIN_BLEND_ALPHA {
            warnings.push(format!(
                "roughness {} under metallic {} is taken as {} (a metal blended over diffuse has no mirror lobe)",
                f.roughness,
                f.metallic,
                MIN_BLEND_ALPHA.sqrt()
            ));
        }
        Surface::Blend { metallic: f.metallic, alpha: alpha.max(MIN_BLEND_ALPHA) }
    };
    Ok((s, warnings))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(
        metallic: f32,
        roughness: f32,
        transmission: f32,
        ior: f32,
        thickness: Option<f32>,
    ) -> Factors {
        Factors { metallic, roughness, transmission, ior, thickness }
    }

    /// Each row of the table, and what is warned about or refused.
    #[test]
    fn factors_map_to_the_table_of_surfaces() {
        let ok = |x: Factors| surface(&x).expect("valid factors");
        assert_eq!(ok(f(0.0, 0.7, 0.0, 1.5, None)), (Surface::Diffuse, vec![]));
        assert_eq!(ok(f(1.0, 0.0, 0.0, 1.5, None)), (Surface::Mirror, vec![]));
        assert_eq!(
            ok(f(1.0, 0.5, 0.0, 1.5, None)),
            (Surface::RoughConductor { alpha: 0.25 }, vec![])
        );
        assert_eq!(
            ok(f(0.3, 0.5, 0.0, 1.5, None)),
            (Surface::Blend { metallic: 0.3, alpha: 0.25 }, vec![])
        );
        assert_eq!(
            ok(f(0.0, 0.0, 1.0, 1.33, Some(0.1))),
            (Surface::Dielectric { eta: 1.33 }, vec![])
        );
        assert_eq!(ok(f(0.0, 0.0, 1.0, 1.5, None)), (Surface::ThinDielectric { eta: 1.5 }, vec![]));
        assert_eq!(ok(f(0.0, 0.0, 1.0, 1.5, Some(0.0))).0, Surface::ThinDielectric { eta: 1.5 });
        let (s, w) = ok(f(0.0, 0.2, 0.5, 1.5, None));
        assert_eq!((s, w.len()), (Surface::ThinDielectric { eta: 1.5 }, 2), "{w:?}");
        let (s, w) = ok(f(0.5, 0.0, 0.0, 1.5, None));
        assert_eq!((s, w.len()), (Surface::Blend { metallic: 0.5, alpha: MIN_BLEND_ALPHA }, 1));
        for bad in [
            f(1.5, 0.0, 0.0, 1.5, None),
            f(0.0, -0.1, 0.0, 1.5, None),
            f(0.0, 0.0, f32::NAN, 1.5, None),
        ] {
            assert!(surface(&bad).is_err_and(|e| e.contains("outside [0, 1]")));
        }
        for ior in [0.0, -1.0, f32::INFINITY, f32::NAN] {
            assert!(surface(&f(0.0, 0.0, 1.0, ior, None))
                .is_err_and(|e| e.contains("index of refraction")));
        }
    }
}
