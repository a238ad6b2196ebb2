#include "geometry/parse_util.h"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace dome::geometry::internal {

std::string ReadTextFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  core::Require(in.good(), path, "cannot open file for reading (missing or unreadable)");
  std::ostringstream content;
  content << in.rdbuf();
  core::Require(!in.bad(), path, "read error");
  return content.str();
}

void WriteTextFile(const std::string& path, const std::string& content) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  core::Require(out.good(), path, "cannot open file for writing");
  out << content;
  out.flush();
  core::Require(out.good(), path, "write error");
}

double ParseDouble(std::string_view text, const std::string& where) {
  const std::string_view trimmed = Trim(text);
  // strtod rather than from_chars: it also takes "+1.5" and hexadecimal, as C tools write.
  const std::string copy(trimmed);
  const char* begin = copy.c_str();
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(begin, &end);
  const bool whole = !copy.empty() && end == begin + copy.size();
  core::Require(whole && errno != ERANGE && std::isfinite(value), where,
                "expected a finite number, got '" + copy + "'");
  return value;
}

int ParseInt(std::string_view text, const std::string& where) {
  const std::string_view trimmed = Trim(text);
  int value = 0;
  const char* begin = trimmed.data();
  const char* end = trimmed.data() + trimmed.size();
  if (begin != end && *begin == '+') {
    ++begin;
  }
  const auto [ptr, ec] = std::from_chars(begin, end, value);
  core::Require(!trimmed.empty() && ec == std::errc() && ptr == end, where,
                "expected an integer, got '" + std::string(trimmed) + "'");
  return value;
}

std::string FormatDouble(double value) {
  // std::to_chars without a precision writes the shortest text that reads back as the
  // same double: exact for files and readable in messages ("-512.3", not
  // "-512.29999999999995").
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string_view Trim(std::string_view text) {
  const char* space = " \t\r\n\v\f";
  const size_t begin = text.find_first_not_of(space);
  if (begin == std::string_view::npos) {
    return {};
  }
  const size_t end = text.find_last_not_of(space);
  return text.substr(begin, end - begin + 1);
}

std::vector<std::string> SplitWhitespace(std::string_view text) {
  std::vector<std::string> tokens;
  std::istringstream in{std::string(text)};
  std::string token;
  while (in >> token) {
    tokens.push_back(token);
  }
  return tokens;
}

std::vector<std::string> SplitLines(std::string_view text) {
  std::vector<std::string> lines;
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string_view::npos) {
      end = text.size();
    }
    std::string_view line = text.substr(start, end - start);
    if (!line.empty() && line.back() == '\r') {
      line.remove_suffix(1);
    }
    lines.emplace_back(line);
    if (end == text.size()) {
      break;
    }
    start = end + 1;
  }
  return lines;
}

void RequireRotation(const Eigen::Matrix3d& rotation, double tolerance, const std::string& where) {
  core::Require(rotation.allFinite(), where, "rotation has a non-finite entry");
  const double orthonormality =
      (rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  core::Require(orthonormality <= tolerance, where,
                "rotation is not orthonormal: max |R R^T - I| = " + FormatDouble(orthonormality) +
                    ", tolerance " + FormatDouble(tolerance));
  const double det = rotation.determinant();
  core::Require(std::abs(det - 1.0) <= tolerance, where,
                "rotation has determinant " + FormatDouble(det) +
                    ", expected +1 (a reflection or a camera->world/world->camera mix-up?)");
}

Eigen::Matrix3d RequireNearRotation(const Eigen::Matrix3d& rotation, double tolerance,
                                    const std::string& where) {
  RequireRotation(rotation, tolerance, where);
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(rotation, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return svd.matrixU() * svd.matrixV().transpose();
}

}  // namespace dome::geometry::internal
