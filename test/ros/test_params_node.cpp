// Parameters from the parameter server (params.test).
#include <std_srvs/Trigger.h>

#include "flexcloud/LoadMap.h"
#include "flexcloud/Save.h"
#include "flexcloud/ros/node_params.h"
#include "ros_test_util.h"
#include "test_util.h"

namespace flexcloud::test {
namespace {

/// Parameters from the parameter server: every wrong value is named, none falls back silently.
TEST(Params, WrongValuesAreNamedAndTheNodeDoesNotStart) {
  ros::NodeHandle nh("/bad_params");
  nh.setParam("control_points", std::string("many"));
  nh.setParam("stddev_threshold", -1.0);
  nh.setParam("interpolation", std::string("cubic"));
  nh.setParam("odom_type", std::string("imu"));
  nh.setParam("datum_lat", 48.0);
  nh.setParam("excluded_ranges", std::string("everything"));
  try {
    loadNodeParams(nh);
    FAIL() << "bad parameters were accepted";
  } catch (const Error& e) {
    const std::string what = e.what();
    for (const char* says :
         {"control_points: 'many' is not a number", "stddev_threshold -1", "interpolation: 'cubic'",
          "odom_type 'imu'", "give all three or none", "excluded_ranges: expected a list"}) {
      EXPECT_NE(what.find(says), std::string::npos) << says << " in: " << what;
    }
    EXPECT_EQ(what.find('\n'), std::string::npos);
  }
  ros::NodeHandle good("/good_params");
  good.setParam("control_points", 50);
  good.setParam("margin_z", 3);  // an int where a double belongs is fine
  const NodeParams p = loadNodeParams(good);
  EXPECT_EQ(p.core.control_points, 50);
  EXPECT_DOUBLE_EQ(p.core.margin_z, 3.0);
  EXPECT_TRUE(unknownNodeParams(good).empty());
}

/// A misspelled parameter is named (the node warns about it) rather than silently ignored.
TEST(Params, MisspelledParametersAreNamed) {
  ros::NodeHandle nh("/misspelled_params");
  nh.setParam("control_points", 50);
  nh.setParam("contol_points", 80);
  nh.setParam("enu_frame", std::string("world"));
  nh.setParam("extra/nested", 1);
  EXPECT_EQ(unknownNodeParams(nh), (std::vector<std::string>{"contol_points", "extra"}));
  EXPECT_EQ(loadNodeParams(nh).core.control_points, 50);
}

/// A nodelet cannot leave its manager (14): with a bad parameter it answers every service with
/// the reason.
TEST(Params, ABadNodeletAnswersEveryServiceWithTheReason) {
  const std::string reason = "control_points 2 is not in [4, 100000]";
  const auto g = call(0, 0.0, "/bad_nodelet");
  EXPECT_FALSE(g.success);
  EXPECT_NE(g.message.find(reason), std::string::npos) << g.message;
  flexcloud::Save save;
  save.request.directory = "/tmp/never";
  save = callService("/bad_nodelet/save", save);
  EXPECT_FALSE(save.response.success);
  EXPECT_NE(save.response.message.find(reason), std::string::npos) << save.response.message;
  const auto reset = callService<std_srvs::Trigger>("/bad_nodelet/reset");
  EXPECT_FALSE(reset.response.success);
  EXPECT_NE(reset.response.message.find(reason), std::string::npos);
  const auto load = callService<flexcloud::LoadMap>("/bad_nodelet/load_map");
  EXPECT_FALSE(load.response.success);
  EXPECT_NE(load.response.message.find(reason), std::string::npos);
}

/// A bag that cannot be read reaches ~result (success false, naming the bag), and so does a
/// ~georeference call refused because of it.
TEST(Params, ABagThatCannotBeReadReachesTheResultTopic) {
  const auto read = messageWhere<Result>(
      "/bagless/result", [](const Result& m) { return !m.success; }, 30.0);
  ASSERT_TRUE(read) << "~result never reported the bag";
  EXPECT_NE(read->message.find("/nonexistent/drive.bag"), std::string::npos) << read->message;
  const ros::Time before = ros::Time::now();
  const auto g = call(0, 0.0, "/bagless");
  EXPECT_FALSE(g.success);
  EXPECT_NE(g.message.find("/nonexistent/drive.bag"), std::string::npos) << g.message;
  const auto after = messageWhere<Result>(
      "/bagless/result", [&](const Result& m) { return m.header.stamp >= before; }, 10.0);
  ASSERT_TRUE(after);
  EXPECT_FALSE(after->success);
  EXPECT_EQ(after->message, g.message);
}

/// A node that has not run yet says so on ~result, with success false.
TEST(Params, BeforeAnyRunTheResultSaysThereIsNone) {
  const auto first = messageWhere<Result>(
      "/idle/result", [](const Result&) { return true; }, 30.0);
  ASSERT_TRUE(first);
  EXPECT_FALSE(first->success);
  EXPECT_FALSE(first->has_result);
  EXPECT_EQ(first->message, "no result yet: call ~georeference");
}

/// The standalone node ends with exit 1 on a bad parameter (14), naming it.
TEST(Params, AStandaloneNodeWithABadParameterExitsWith1) {
  const auto r = sh(std::string(FLEXCLOUD_BIN_DIR) +
                    "/georeference_node __name:=bad_standalone _control_points:=2 "
                    "_odom_type:=imu");
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("control_points 2 is not in [4, 100000]"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("odom_type 'imu'"), std::string::npos) << r.output;
  ros::param::del("/bad_standalone");
}

}  // namespace
}  // namespace flexcloud::test
