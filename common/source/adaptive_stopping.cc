#include <vi/adaptive_stopping.h>

namespace VI
{
  Json
  to_json(const std::vector<EstimateRecord> &records, const bool with_eta)
  {
    Json list = Json::array();
    for (const EstimateRecord &r : records)
      {
        Json it        = Json::object();
        it["k"]        = r.newton_step;
        it["i"]        = r.linear_iteration;
        it["accepted"] = r.accepted;
        if (!r.estimate.complete)
          // the flux-free terms only: eta_lin from below, eta_alg from above
          it["fluxes"] = false;
        else
          {
            if (with_eta)
              it["eta"] = r.estimate.eta;
            it["eta_disc"] = r.estimate.eta_disc;
          }
        it["eta_lin"] = r.estimate.eta_lin;
        it["eta_alg"] = r.estimate.eta_alg;
        list.push_back(it);
      }
    return list;
  }
} // namespace VI
