// The JSON writer of summary.json.
#include <vi/summary.h>

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

TEST(Json, WritesNestedObjectsInInsertionOrder)
{
  VI::Json summary     = VI::Json::object();
  summary["program"]   = "step-x";
  summary["mpi_ranks"] = 2u;
  summary["ok"]        = true;
  summary["nothing"]   = VI::Json();
  summary["values"].push_back(1.5);
  summary["values"].push_back(std::nan(""));
  VI::Json record = VI::Json::object();
  record["k"]     = 1;
  record["eta"]   = 1.25e-3;
  summary["records"].push_back(record);
  summary["raw"]  = VI::Json::raw("{\"a\": 1}");
  summary["text"] = "quote \" backslash \\ newline \n";

  std::ostringstream out;
  summary.write(out);
  EXPECT_EQ(out.str(),
            "{\n"
            "  \"program\": \"step-x\",\n"
            "  \"mpi_ranks\": 2,\n"
            "  \"ok\": true,\n"
            "  \"nothing\": null,\n"
            "  \"values\": [1.5, null],\n"
            "  \"records\": [\n"
            "    {\n"
            "      \"k\": 1,\n"
            "      \"eta\": 0.00125\n"
            "    }\n"
            "  ],\n"
            "  \"raw\": {\"a\": 1},\n"
            "  \"text\": \"quote \\\" backslash \\\\ newline \\n\"\n"
            "}");
  EXPECT_EQ(summary.size(), 8u);
}


TEST(Json, NewtonStepsCarryTheActiveSetsWhereKnown)
{
  VI::NewtonReport report;
  for (unsigned int k = 1; k <= 2; ++k)
    {
      VI::NewtonStep step;
      step.iteration         = k;
      step.linear_iterations = 10 * k;
      step.has_active_set    = true;
      step.active_set        = {100ull - k, k == 1 ? 0ull : 7ull};
      report.steps.push_back(step);
    }
  VI::NewtonStep without;
  without.iteration = 3;
  report.steps.push_back(without);

  std::ostringstream out;
  VI::newton_steps(report).write(out);
  const std::string text = out.str();
  EXPECT_NE(text.find("\"active_rows\": 99\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\"active_rows\": 98,"), std::string::npos) << text;
  // The first linearisation has nothing to switch from.
  EXPECT_EQ(text.find("\"switched_rows\": 0"), std::string::npos) << text;
  EXPECT_NE(text.find("\"switched_rows\": 7"), std::string::npos) << text;
  // A step without an active set says nothing about it.
  EXPECT_EQ(text.rfind("\"active_rows\""), text.find("\"active_rows\": 98,"))
    << text;
  EXPECT_NE(VI::describe(report.steps[1])
              .find("20 linear iterations, 98 active rows (7 switched)"),
            std::string::npos)
    << VI::describe(report.steps[1]);
}
