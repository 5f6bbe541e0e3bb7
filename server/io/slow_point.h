#pragma once
// Fault injection for the timing tests, as crash_point.h is for the crash tests: with
// TEXTOND_SLOW_POINT="<point>=<factor>[,<point>=<factor>...]" in its environment the process
// makes the work at that point take <factor> times its admission estimate longer, so a test can
// hold work past a deadline or in a queue on a machine of any speed. Points:
//   render     an admitted image render (image routes), before the backend runs
//   analysis   an analysis that left the queue, before it runs
//   load       a splat or mix read from its files and prepared (estimate 1 s: the factor is
//              seconds), after its files are read, before it is prepared and kept
// The wait polls `stop` every 10 ms and ends as soon as it says so. Unset: no cost but a lookup.
#include <functional>
#include <string_view>

namespace textond::io {

// False when `stop` ended the wait (the work should give up as if it had been stopped).
bool slow_point(std::string_view name, double estimate_s, const std::function<bool()>& stop = {});

} // namespace textond::io
