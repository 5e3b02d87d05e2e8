#include "nerfreg/util/json_util.h"

#include <cmath>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {

Json ParseJson(const std::string& text, const std::string& source) {
  bool too_deep = false;
  Json json;
  try {
    json = Json::parse(text, [&](int depth, Json::parse_event_t, Json&) {
      if (depth > kMaxJsonDepth) {
        too_deep = true;
        throw std::length_error("nesting");
      }
      return true;
    });
  } catch (const Json::exception& e) {
    // parse_error, and out_of_range for numbers too large for a double (found by fuzzing).
    ThrowInputError(source, "", std::string("valid JSON (") + e.what() + ")");
  } catch (const std::length_error&) {
    if (!too_deep) throw;
    ThrowInputError(source, "", "JSON nested at most " + std::to_string(kMaxJsonDepth) + " levels deep");
  }
  return json;
}

Json ReadJsonFile(const std::string& path) { return ParseJson(ReadFileToString(path), path); }

void WriteJsonFile(const std::string& path, const Json& json, int indent) {
  WriteFileAtomic(path, json.dump(indent) + "\n");
}

void JsonField::Fail(const std::string& expected) const {
  ThrowInputError(file_, path_.empty() ? "(top level)" : path_, expected);
}

bool JsonField::Has(const std::string& key) const { return json_->is_object() && json_->contains(key); }

JsonField JsonField::operator[](const std::string& key) const {
  const std::string child = path_.empty() ? key : path_ + "." + key;
  if (!json_->is_object()) Fail("an object with field '" + key + "'");
  auto it = json_->find(key);
  if (it == json_->end()) ThrowInputError(file_, child, "a value (field is missing)");
  return JsonField(*it, file_, child);
}

JsonField JsonField::operator[](size_t index) const {
  if (!json_->is_array()) Fail("an array");
  if (index >= json_->size()) Fail("an array with more than " + std::to_string(index) + " items");
  return JsonField((*json_)[index], file_, path_ + "[" + std::to_string(index) + "]");
}

size_t JsonField::ArraySize() const {
  if (!json_->is_array()) Fail("an array");
  return json_->size();
}

double JsonField::Double() const {
  if (!json_->is_number()) Fail("a number");
  const double v = json_->get<double>();
  if (!std::isfinite(v)) Fail("a finite number");
  return v;
}

int JsonField::Int() const {
  if (!json_->is_number_integer()) Fail("an integer");
  return json_->get<int>();
}

std::string JsonField::String() const {
  if (!json_->is_string()) Fail("a string");
  return json_->get<std::string>();
}

bool JsonField::Bool() const {
  if (!json_->is_boolean()) Fail("true or false");
  return json_->get<bool>();
}

std::vector<double> JsonField::Doubles() const {
  const size_t n = ArraySize();
  std::vector<double> out(n);
  for (size_t i = 0; i < n; ++i) out[i] = (*this)[i].Double();
  return out;
}

std::vector<std::int64_t> JsonField::Int64s() const {
  const size_t n = ArraySize();
  std::vector<std::int64_t> out(n);
  for (size_t i = 0; i < n; ++i) out[i] = (*this)[i].Int();
  return out;
}

Eigen::MatrixXd JsonField::Matrix(int rows, int cols) const {
  const std::string shape = std::to_string(rows) + "x" + std::to_string(cols);
  if (!json_->is_array() || static_cast<int>(json_->size()) != rows) {
    Fail("a " + shape + " matrix (array of " + std::to_string(rows) + " rows)");
  }
  Eigen::MatrixXd m(rows, cols);
  for (int r = 0; r < rows; ++r) {
    const JsonField row = (*this)[r];
    if (!row.json().is_array() || static_cast<int>(row.json().size()) != cols) {
      row.Fail("a row of " + std::to_string(cols) + " numbers (" + shape + " matrix)");
    }
    for (int c = 0; c < cols; ++c) m(r, c) = row[c].Double();
  }
  return m;
}

double JsonField::DoubleOr(const std::string& key, double fallback) const {
  return Has(key) && !(*json_)[key].is_null() ? (*this)[key].Double() : fallback;
}

int JsonField::IntOr(const std::string& key, int fallback) const {
  return Has(key) && !(*json_)[key].is_null() ? (*this)[key].Int() : fallback;
}

std::string JsonField::StringOr(const std::string& key, const std::string& fallback) const {
  return Has(key) && !(*json_)[key].is_null() ? (*this)[key].String() : fallback;
}

bool JsonField::BoolOr(const std::string& key, bool fallback) const {
  return Has(key) && !(*json_)[key].is_null() ? (*this)[key].Bool() : fallback;
}

Json MatrixToJson(const Eigen::MatrixXd& m) {
  Json rows = Json::array();
  for (int r = 0; r < m.rows(); ++r) {
    Json row = Json::array();
    for (int c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
    rows.push_back(row);
  }
  return rows;
}

}  // namespace nerfreg
