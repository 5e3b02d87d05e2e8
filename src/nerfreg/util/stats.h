#pragma once
// Order statistics of small samples, written once for every layer.
#include <vector>

namespace nerfreg {

// The median; with an even count, the mean of the two middle values. 0 for no values.
double Median(std::vector<double> values);

// The upper median: the value at index size / 2 once sorted (with an even count, the larger of the
// two middle values; no averaging). 0 for no values.
double UpperMedian(std::vector<double> values);

}  // namespace nerfreg
