// Robustness checks of Ahmad2020 (docs/models.md, 'Ahmad2020'): the weighted nominal
// performance norms and robust stability over a coefficient family.
//
// What is computed:
//  * nominal: ||H_e S||∞ and ||H_y T||∞ (nominal performance needs both < 1)
//    and ||H_m T||∞, the robust-stability measure for multiplicative
//    uncertainty G_p = G (1 + Δ H_m), ||Δ||∞ <= 1: the loop is robustly
//    stable for that whole set iff ||H_m T||∞ < 1 (small-gain theorem).
//  * coefficient family: every combination of the plant's denominator
//    coefficients (all but the leading one) scaled by 1 − rel, 1, 1 + rel
//    (3^6 = 729 plants for Ahmad2020's G, rel = 0.05). For each member G_i:
//    closed-loop stability with K (eigenvalues of the interconnection, as in
//    analysis.hpp), ||H_m T_i||∞ with T_i = G_i K / (1 + G_i K), and how far
//    it leaves the weight: c_i = sup_ω |G_i/G − 1| / |H_m| on the analysis
//    grid (c_i <= 1: the member lies inside the set H_m describes, so the
//    nominal test above covers it; ω = 0 is included). Reported: how many
//    members are unstable, the worst stability measure (max real part of the
//    poles, or max |z|) and its member, the largest ||H_m T_i||∞ among the
//    stable members and its member, and the largest c_i and its member.
// With ts > 0 every model (plant members, controller, weights) is taken as
// continuous and discretised by Tustin at ts before the analysis.
#pragma once

#include <vector>

#include "analysis/hinf.hpp"
#include "lti/lti.hpp"

namespace piezoloop::design {

struct FamilyMember {
    std::vector<double> scale;  // factor applied to den[1..n]
    double stability_measure = 0.0;
    bool stable = false;
    double hinf_HmT = 0.0;
    double coverage = 0.0;
};

struct FamilyResult {
    int count = 0;
    int unstable = 0;
    FamilyMember worst_stability;  // largest stability measure
    FamilyMember worst_hinf_HmT;   // largest ||H_m T_i|| among the stable members
    FamilyMember worst_coverage;   // largest c_i
};

// plant: Tf whose denominator is perturbed; controller and hm: any models.
// rel in (0, 0.5); at most 8 perturbed coefficients (3^8 members).
FamilyResult coefficient_family(const Tf& plant, const Zpk& controller, const Zpk& hm, double rel = 0.05,
                                double ts = 0.0);

}  // namespace piezoloop::design
