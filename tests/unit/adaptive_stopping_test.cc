// VI::AdaptiveStopping with a made-up iterate and estimate: the GMRES
// checks with and without look-ahead, the predicted checks, the accepted
// update, the Newton criterion and the records; and the progress line of
// run_record.h.
#include <deal.II/base/index_set.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vi/adaptive_stopping.h>
#include <vi/run_record.h>

#include <gtest/gtest.h>

#include <utility>

namespace
{
  using MPIVector = dealii::TrilinosWrappers::MPI::Vector;

  struct Iterate
  {
    MPIVector    X;
    unsigned int linear_iteration = 0;
  };

  /// eta_disc = 1, eta_lin = 0.2; eta_alg = 1 for an iterate's own estimate
  /// and 0.01 with a look-ahead (which is what makes the look-ahead sharper
  /// in the real estimators).
  struct Estimate
  {
    bool   complete = true;
    double eta_disc = 1, eta_lin = 0.2, eta_alg = 1;
  };

  struct AdaptiveStoppingTest : public ::testing::Test
  {
    AdaptiveStoppingTest()
    {
      parameters.strategy  = VI::Strategy::adaptive;
      parameters.gamma_alg = 0.3;
      parameters.gamma_lin = 0.3;
      point.reinit(dealii::complete_index_set(1), MPI_COMM_WORLD);
      point = 1.;

      hooks.describe = [](const MPIVector &X, Iterate &it) { it.X = X; };
      hooks.estimate = [this](const Iterate &it, const Iterate &ahead) {
        ++n_estimates;
        Estimate e;
        e.eta_alg = &it == &ahead ? 1. : 0.01;
        return e;
      };
      hooks.estimate_iterate = [this](const MPIVector &) {
        ++n_iterate_estimates;
        return Estimate();
      };
      hooks.components = [](const Estimate &e) {
        return VI::StoppingComponents{
          e.complete, 0., e.eta_disc, e.eta_lin, e.eta_alg, e.eta_lin};
      };
    }

    MPIVector
    update(const double value) const
    {
      MPIVector u(point);
      u = value;
      return u;
    }

    /// The first Newton step of a solve, from `point`: GMRES reports the
    /// update 0.5 after 10 iterations, then 0.25 after 20. Returns what the
    /// monitor answered each time (true: GMRES may stop).
    std::pair<bool, bool>
    first_step_gmres(VI::AdaptiveStopping<Iterate, Estimate> &stopping)
    {
      stopping.start_solve();
      stopping.start_step(point);
      const auto monitor      = stopping.gmres_monitor();
      const bool after_first  = monitor(update(0.5), 10);
      const bool after_second = monitor(update(0.25), 20);
      return {after_first, after_second};
    }

    VI::NonlinearSolverParameters                  parameters;
    VI::AdaptiveStopping<Iterate, Estimate>::Hooks hooks;
    MPIVector                                      point;
    unsigned int n_estimates = 0, n_iterate_estimates = 0;
  };
} // namespace


// The first check has no previous iterate and its own estimate fails the
// GMRES test; the second accepts the first check's iterate, estimated with
// the second as look-ahead, and hands its update back.
TEST_F(AdaptiveStoppingTest, AcceptsThePreviousIterateWithItsLookAhead)
{
  VI::AdaptiveStopping<Iterate, Estimate> stopping(parameters, hooks);
  EXPECT_EQ(first_step_gmres(stopping), std::make_pair(false, true));
  EXPECT_EQ(n_estimates, 3u);

  MPIVector dX = update(0.);
  EXPECT_TRUE(stopping.accepted_update_of_step()(dX));
  EXPECT_DOUBLE_EQ(dX[0], 0.5);

  ASSERT_EQ(stopping.records.size(), 3u);
  EXPECT_EQ(stopping.records[0].linear_iteration, 10u);
  EXPECT_EQ(stopping.records[1].linear_iteration, 20u);
  EXPECT_EQ(stopping.records[2].linear_iteration, 10u);
  EXPECT_DOUBLE_EQ(stopping.records[2].estimate.eta_alg, 0.01);
  for (const VI::EstimateRecord &r : stopping.records)
    {
      EXPECT_EQ(r.newton_step, 1u);
      EXPECT_FALSE(r.accepted);
    }

  // The Newton iterate is the accepted one: its estimate is reused, and
  // eta_lin = 0.2 <= 0.3 eta_disc ends the iteration.
  VI::NewtonStep step;
  step.linear_iterations = 20;
  EXPECT_TRUE(stopping.newton_criterion(point, step));
  EXPECT_TRUE(stopping.step_is_certified());
  EXPECT_EQ(n_iterate_estimates, 0u);
  ASSERT_TRUE(stopping.final_estimate.has_value());
  EXPECT_TRUE(stopping.records.back().accepted);
}


// Without look-ahead (the dG estimate) each check estimates its own
// iterate only: the second check's own estimate fails the GMRES test too,
// and GMRES goes on. (With the look-ahead the previous iterate passed.)
TEST_F(AdaptiveStoppingTest, WithoutLookAheadEachCheckEstimatesItsOwnIterate)
{
  hooks.look_ahead = false;
  VI::AdaptiveStopping<Iterate, Estimate> stopping(parameters, hooks);
  EXPECT_EQ(first_step_gmres(stopping), std::make_pair(false, false));
  EXPECT_EQ(n_estimates, 2u);
  ASSERT_EQ(stopping.records.size(), 2u);
  for (const VI::EstimateRecord &r : stopping.records)
    EXPECT_DOUBLE_EQ(r.estimate.eta_alg, 1.);
  MPIVector dX = update(0.75);
  EXPECT_FALSE(stopping.accepted_update_of_step()(dX));
}


// The schedule asks for a check where the last check's eta_alg / residual
// times GMRES's residual is a hundredth of that check's threshold gamma_alg
// max(eta_disc, eta_lin) = 0.3 and the residual has met the forcing term
// 1e-2; nothing before the first check of a solve, and nothing for the other
// strategies.
TEST_F(AdaptiveStoppingTest, ScheduleAsksWhereTheResidualPredictsAPass)
{
  VI::AdaptiveStopping<Iterate, Estimate> stopping(parameters, hooks);
  stopping.start_solve();
  stopping.start_step(point);
  const auto monitor  = stopping.gmres_monitor();
  const auto schedule = stopping.gmres_schedule();
  EXPECT_FALSE(schedule(1, 1e-12, 1.));
  EXPECT_FALSE(schedule(10, 0.5, 1.));
  EXPECT_FALSE(monitor(update(0.5), 10));  // eta_alg = 1: 2 per residual
  EXPECT_FALSE(schedule(11, 0.002, 1.));   // predicts 0.004 > 0.003
  EXPECT_TRUE(schedule(12, 0.001, 1.));    // predicts 0.002
  EXPECT_FALSE(schedule(12, 0.001, 0.05)); // above the forcing term

  stopping.start_solve();
  EXPECT_FALSE(schedule(1, 1e-12, 1.));

  parameters.strategy = VI::Strategy::inexact;
  VI::AdaptiveStopping<Iterate, Estimate> recording(parameters, hooks);
  recording.start_solve();
  recording.start_step(point);
  const auto recording_schedule = recording.gmres_schedule();
  recording_schedule(10, 0.5, 1.);
  recording.gmres_monitor()(update(0.5), 10);
  EXPECT_FALSE(recording_schedule(12, 1e-12, 1.));
}


// With the size of its problem, a solve starts from the last one's
// eta_alg / |r| and threshold, scaled to the new mesh: four times the
// unknowns in 2D with Q1 double eta_alg / |r| (2 -> 4) and halve the
// threshold (0.3 -> 0.15), so the first check is asked where 4 |r| <=
// 0.0015. On the same mesh (a time step) nothing is scaled; a checkpoint
// carries the prediction.
TEST_F(AdaptiveStoppingTest, ScheduleCarriesThePredictionToTheNextSolve)
{
  using Stopping = VI::AdaptiveStopping<Iterate, Estimate>;
  Stopping stopping(parameters, hooks);
  stopping.start_solve({1000., 2, 1});
  stopping.start_step(point);
  const auto schedule = stopping.gmres_schedule();
  EXPECT_FALSE(schedule(10, 0.5, 1.));
  EXPECT_FALSE(stopping.gmres_monitor()(update(0.5), 10));

  stopping.start_solve({4000., 2, 1});
  stopping.start_step(point);
  EXPECT_FALSE(schedule(3, 4e-4, 1.));  // predicts 1.6e-3 > 1.5e-3
  EXPECT_TRUE(schedule(4, 3.5e-4, 1.)); // predicts 1.4e-3

  const Stopping::Prediction learnt = stopping.learnt_prediction();
  EXPECT_DOUBLE_EQ(learnt.alg_per_residual, 4.);
  EXPECT_DOUBLE_EQ(learnt.alg_threshold, 0.15);
  EXPECT_DOUBLE_EQ(learnt.unknowns, 4000.);

  Stopping resumed(parameters, hooks);
  resumed.restore_prediction(learnt);
  resumed.start_solve({4000., 2, 1});
  EXPECT_TRUE(resumed.gmres_schedule()(4, 3.5e-4, 1.));

  stopping.start_solve();
  EXPECT_FALSE(schedule(4, 1e-12, 1.));
}


// The other strategies only record: GMRES runs to its tolerance, and a
// shortened step (line search) is estimated afresh.
TEST_F(AdaptiveStoppingTest, OtherStrategiesOnlyRecord)
{
  parameters.strategy = VI::Strategy::inexact;
  VI::AdaptiveStopping<Iterate, Estimate> stopping(parameters, hooks);
  EXPECT_EQ(first_step_gmres(stopping), std::make_pair(false, false));
  MPIVector dX = update(0.75);
  EXPECT_FALSE(stopping.accepted_update_of_step()(dX));
  EXPECT_DOUBLE_EQ(dX[0], 0.75);

  VI::NewtonStep step;
  step.step_length = 0.5;
  EXPECT_FALSE(stopping.newton_criterion(point, step));
  EXPECT_EQ(n_iterate_estimates, 1u);
  EXPECT_EQ(stopping.records.size(), 4u);
}


// An estimate of the flux-free terms only (decide_early) ends GMRES but
// not Newton, and is not the solve's final estimate.
TEST_F(AdaptiveStoppingTest, AFluxFreeDecisionDoesNotEndNewton)
{
  hooks.decide_early = [](Iterate &) -> std::optional<Estimate> {
    Estimate e;
    e.complete = false;
    e.eta_alg  = 0.;
    return e;
  };
  VI::AdaptiveStopping<Iterate, Estimate> stopping(parameters, hooks);
  stopping.start_solve();
  stopping.start_step(point);
  EXPECT_TRUE(stopping.gmres_monitor()(update(0.5), 10));
  EXPECT_FALSE(stopping.step_is_certified());
  EXPECT_FALSE(stopping.newton_criterion(point, VI::NewtonStep()));
  EXPECT_FALSE(stopping.final_estimate.has_value());

  const VI::Json     records = VI::to_json(stopping.records, true);
  std::ostringstream text;
  records.write(text);
  EXPECT_NE(text.str().find("\"fluxes\": false"), std::string::npos);
}


TEST(CycleNumbers, LineNamesTheKnownParts)
{
  VI::CycleNumbers line;
  line.solver            = "Newton-min";
  line.newton_iterations = 3;
  line.contact_nodes     = 12;
  line.seconds           = 0.5;
  EXPECT_EQ(VI::to_string(line),
            "   Newton-min: 3 iterations, 12 nodes in contact, 0.5 s");
  line.linear_iterations = 40;
  line.linear_solver     = "GMRES";
  line.error_energy      = 0.01;
  line.estimate          = 0.011;
  EXPECT_EQ(VI::to_string(line),
            "   Newton-min: 3 iterations, 40 GMRES, 12 nodes in contact, "
            "energy error 1.000e-02, estimate 1.100e-02 (effectivity 1.1), "
            "0.5 s");
}


TEST(CycleNumbers, RecordKeepsWhatWasMeasured)
{
  VI::CycleNumbers numbers;
  numbers.cycle   = 2;
  const auto text = [&]() {
    std::ostringstream out;
    VI::to_json(numbers).write(out);
    return out.str();
  };
  EXPECT_EQ(text().find("error_energy"), std::string::npos);
  EXPECT_EQ(text().find("effectivity"), std::string::npos);
  numbers.error_energy = 0.5;
  numbers.estimate     = 0.75;
  EXPECT_NE(text().find("\"effectivity\": 1.5"), std::string::npos);

  const VI::ErrorColumns errors{true, true, true};
  EXPECT_EQ(errors.rate_keys(),
            (std::vector<std::string>{"error_energy", "error_lambda", "eta"}));
  // A multiplier error is tabulated only beside the energy error.
  EXPECT_EQ((VI::ErrorColumns{false, true, false}.rate_keys()),
            std::vector<std::string>{});
}
