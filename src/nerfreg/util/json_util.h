#pragma once
// Reading JSON written by users and other tools: every accessor names the file and the field path
// ("frames[3].transform_matrix") in its error, so a bad input produces one actionable line.
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <cstdint>
#include <string>
#include <vector>

namespace nerfreg {

using Json = nlohmann::json;

// Parses a JSON file. Throws InputError("FILE: expected valid JSON (...)") on syntax errors.
Json ReadJsonFile(const std::string& path);

// Deepest nesting of arrays and objects any reader accepts. Readers of nested documents recurse
// (nlohmann's msgpack reader, our report's tables), so a few KB of "[[[[..." would overflow the
// stack; no file of ours nests deeper than ~8.
constexpr int kMaxJsonDepth = 64;

// Parses JSON text; `source` names it in errors. Throws InputError on invalid JSON or nesting
// deeper than kMaxJsonDepth.
Json ParseJson(const std::string& text, const std::string& source);

// Writes JSON atomically, pretty-printed with `indent` spaces.
void WriteJsonFile(const std::string& path, const Json& json, int indent = 2);

// A view on one JSON object with its file and field path, for error messages.
class JsonField {
 public:
  JsonField(const Json& json, std::string file, std::string path = "")
      : json_(&json), file_(std::move(file)), path_(std::move(path)) {}

  const Json& json() const { return *json_; }
  const std::string& file() const { return file_; }
  const std::string& path() const { return path_; }

  bool Has(const std::string& key) const;
  JsonField operator[](const std::string& key) const;  // throws if missing
  JsonField operator[](size_t index) const;            // throws if out of range / not array
  size_t ArraySize() const;                            // throws if not an array

  double Double() const;
  int Int() const;
  std::string String() const;
  bool Bool() const;
  std::vector<double> Doubles() const;
  std::vector<std::int64_t> Int64s() const;  // an array of integers (each as Int())
  // A rows x cols numeric matrix written as an array of row arrays (row-major, as in
  // transforms.json). Throws on wrong shape, non-numbers, NaN or inf.
  Eigen::MatrixXd Matrix(int rows, int cols) const;

  // Optional fields: default when absent; type checked when present.
  double DoubleOr(const std::string& key, double fallback) const;
  int IntOr(const std::string& key, int fallback) const;
  std::string StringOr(const std::string& key, const std::string& fallback) const;
  bool BoolOr(const std::string& key, bool fallback) const;

  [[noreturn]] void Fail(const std::string& expected) const;

 private:
  const Json* json_;
  std::string file_;
  std::string path_;
};

// Matrix as a JSON array of rows.
Json MatrixToJson(const Eigen::MatrixXd& m);

}  // namespace nerfreg
