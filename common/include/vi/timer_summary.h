#pragma once

#include <deal.II/base/timer.h>

#include <vi/summary.h>

namespace VI
{
  /// The wall time of every section of `timer` so far, by section name:
  /// the "timing" object of summary.json.
  inline Json
  section_wall_times(const dealii::TimerOutput &timer)
  {
    Json timing = Json::object();
    for (const auto &[section, seconds] :
         timer.get_summary_data(dealii::TimerOutput::total_wall_time))
      timing[section] = seconds;
    return timing;
  }
} // namespace VI
