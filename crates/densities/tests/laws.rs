//! The density law suite (`testing::laws`, through `density_laws!`) run on every family, one line
//! each: normalisation, mode, moments and sampler against quadrature on the family's space, and the
//! laws of the traits it implements (product and its log evidence, KL, entropy, rotation), over the
//! whole parameter range the quadrature resolves (κ from 0 and 1e-300 to 1e6, heat-kernel variances
//! from 1e-6 to 10, Bingham eigenvalue spreads to 1e4, standard deviations from 1e-6 rad); and
//! finiteness at the ends of the accepted range (κ to 1e300, variances from 1e-300 to f64::MAX).

use liebayes_densities::density_laws;
use liebayes_densities::testing::strategies as st;
use liebayes_manifolds::testing::strategies as ms;
use proptest::prelude::*;

/// Standard deviations for Gaussians on Rⁿ: log-uniform over [1e-3, 1e3].
fn wide_deviation() -> impl Strategy<Value = f64> {
    (-3.0..3.0_f64).prop_map(|e| 10f64.powf(e))
}

density_laws!(
    von_mises,
    st::von_mises(st::concentration()),
    product,
    kl,
    entropy,
    rotated(ms::so2::<f64>()),
    finite(st::von_mises(st::extreme_concentration())),
    bad_input(st::von_mises_raw())
);

density_laws!(
    gen_von_mises2,
    st::gen_von_mises2(st::concentration()),
    product,
    kl,
    entropy,
    rotated(ms::so2::<f64>()),
    bad_input(st::gen_von_mises2_raw())
);

density_laws!(
    von_mises_fisher,
    st::von_mises_fisher(st::concentration()),
    product,
    kl,
    entropy,
    rotated(ms::so3::<f64>()),
    finite(st::von_mises_fisher(st::extreme_concentration())),
    bad_input(st::von_mises_fisher_raw())
);

density_laws!(
    bingham,
    st::bingham(1e4),
    product,
    kl,
    entropy,
    rotated(ms::su2::<f64>()),
    finite(st::bingham(liebayes_densities::Bingham::MAX_SPREAD)),
    bad_input(st::bingham_raw())
);

density_laws!(
    heat_kernel_so3,
    st::heat_kernel_so3(st::variance()),
    kl,
    entropy,
    rotated(ms::so3::<f64>()),
    finite(st::heat_kernel_so3(st::extreme_variance())),
    bad_input(st::heat_kernel_so3_raw())
);

density_laws!(
    gaussian_1,
    st::gaussian::<1>(),
    product,
    kl,
    entropy,
    bad_input(st::gaussian_raw::<1>())
);

density_laws!(
    gaussian_3,
    st::gaussian::<3>(),
    product,
    kl,
    entropy,
    bad_input(st::gaussian_raw::<3>())
);

density_laws!(
    manifold_gaussian_so2,
    st::manifold_gaussian::<_, 1>(ms::so2::<f64>(), st::standard_deviation()),
    entropy,
    rotated(ms::so2::<f64>()),
    bad_input(st::manifold_gaussian_raw::<_, 1>(ms::so2::<f64>()))
);

density_laws!(
    manifold_gaussian_so3,
    st::manifold_gaussian::<_, 3>(ms::so3::<f64>(), st::standard_deviation()),
    entropy,
    rotated(ms::so3::<f64>()),
    bad_input(st::manifold_gaussian_raw::<_, 3>(ms::so3::<f64>()))
);

density_laws!(
    manifold_gaussian_world_frame_so3,
    st::manifold_gaussian::<_, 3>(ms::left(ms::so3::<f64>()), st::standard_deviation()),
    entropy,
    rotated(ms::left(ms::so3::<f64>())),
    bad_input(st::manifold_gaussian_raw::<_, 3>(
        ms::left(ms::so3::<f64>())
    ))
);

density_laws!(
    manifold_gaussian_rn,
    st::manifold_gaussian::<_, 3>(ms::rn::<f64, 3>(), wide_deviation()),
    entropy,
    rotated(ms::rn::<f64, 3>()),
    bad_input(st::manifold_gaussian_raw::<_, 3>(ms::rn::<f64, 3>()))
);

density_laws!(
    manifold_gaussian_product,
    st::manifold_gaussian::<_, 6>(
        ms::product::<_, _, 3, 3, 6>(ms::so3::<f64>(), ms::rn::<f64, 3>()),
        st::standard_deviation()
    ),
    entropy,
    rotated(ms::product::<_, _, 3, 3, 6>(
        ms::so3::<f64>(),
        ms::rn::<f64, 3>()
    )),
    bad_input(st::manifold_gaussian_raw::<_, 6>(ms::product::<
        _,
        _,
        3,
        3,
        6,
    >(
        ms::so3::<f64>(),
        ms::rn::<f64, 3>()
    )))
);

density_laws!(
    manifold_gaussian_s2,
    st::manifold_gaussian::<_, 2>(ms::s2::<f64>(), st::standard_deviation()),
    entropy,
    bad_input(st::manifold_gaussian_raw::<_, 2>(ms::s2::<f64>()))
);

density_laws!(
    manifold_gaussian_se2,
    st::manifold_gaussian::<_, 3>(ms::se2::<f64>(), st::standard_deviation()),
    entropy,
    rotated(ms::se2::<f64>()),
    bad_input(st::manifold_gaussian_raw::<_, 3>(ms::se2::<f64>()))
);

density_laws!(
    manifold_gaussian_se23,
    st::manifold_gaussian::<_, 9>(ms::se23::<f64>(), st::standard_deviation()),
    entropy,
    rotated(ms::se23::<f64>()),
    bad_input(st::manifold_gaussian_raw::<_, 9>(ms::se23::<f64>()))
);

density_laws!(
    manifold_gaussian_se3,
    st::manifold_gaussian::<_, 6>(ms::se3::<f64>(), st::standard_deviation()),
    entropy,
    rotated(ms::se3::<f64>()),
    bad_input(st::manifold_gaussian_raw::<_, 6>(ms::se3::<f64>()))
);

density_laws!(
    harmonic_gaussian,
    st::harmonic_gaussian::<2>(st::concentration()),
    kl,
    entropy,
    bad_input(st::harmonic_gaussian_raw::<2>())
);
