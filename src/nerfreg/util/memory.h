#pragma once

namespace nerfreg {

// The most memory this process has held resident so far, in MB (2^20 bytes): getrusage's maximum
// resident set size, what GNU time reports. Long runs write it beside their stage times, so a
// user sees what a folder of photos took without a profiler (issue 44).
double PeakResidentMegabytes();

}  // namespace nerfreg
