#include "ident/reduce_report.hpp"

#include "ident/balred.hpp"
#include "lti/lti_convert.hpp"
#include "lti/model_json.hpp"

namespace piezoloop::design {

nlohmann::json reduce_report(const Zpk& full, int order) {
    const BalancedTruncation bt = balanced_truncation(zpk2ss(full), order);
    nlohmann::json out;
    out["model"] = to_json(ss2zpk(bt.reduced));
    out["order"] = bt.order;
    out["original_order"] = bt.hsv.size();
    out["hsv"] = bt.hsv;
    out["error_bound"] = bt.error_bound;
    return out;
}

}  // namespace piezoloop::design
