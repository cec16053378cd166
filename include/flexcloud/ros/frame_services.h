#pragma once
// The answers of ~to_ll, ~from_ll and ~to_enu for a result: the conversions of
// flexcloud/geo/frame_convert.h in the services' messages.

#include <flexcloud/FromLL.h>
#include <flexcloud/ToEnu.h>
#include <flexcloud/ToLL.h>

#include "flexcloud/ros/result_publisher.h"

namespace flexcloud {

/// Throw Error with the reason (unknown frame, no datum, sheet not invertible); the node's
/// services turn that into success false.
ToLL::Response toLL(const NodeResult& r, const ToLL::Request& req);
FromLL::Response fromLL(const NodeResult& r, const FromLL::Request& req);
ToEnu::Response toEnu(const NodeResult& r, const ToEnu::Request& req);

}  // namespace flexcloud
