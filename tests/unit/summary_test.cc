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
