// Small text and file helpers shared by the camera-file readers and writers of
// dome_geometry (tsai_xml, halcon, middlebury, colmap). Internal to the library: other
// libraries should not include this header.
//
// Every failure is a core::InputError whose `where` is the file (and field) at fault.
#pragma once

#include <Eigen/Core>
#include <string>
#include <string_view>
#include <vector>

namespace dome::geometry::internal {

// Whole file as a string; InputError(path, "cannot open ...") when it cannot be read.
std::string ReadTextFile(const std::string& path);
// Writes `content` to `path` (replacing it); InputError(path, ...) on failure.
void WriteTextFile(const std::string& path, const std::string& content);

// Parses the whole of `text` (surrounding white space allowed) as a finite double;
// otherwise InputError(where, "expected a finite number, got '...'").
double ParseDouble(std::string_view text, const std::string& where);
// Parses the whole of `text` as a base-10 int; otherwise InputError(where, ...).
int ParseInt(std::string_view text, const std::string& where);

// Shortest text that ParseDouble turns back into the same double (round trip exact).
std::string FormatDouble(double value);

std::string_view Trim(std::string_view text);
std::vector<std::string> SplitWhitespace(std::string_view text);
// Splits into lines at '\n', dropping a trailing '\r' from each line.
std::vector<std::string> SplitLines(std::string_view text);

// Requires `rotation` to be orthonormal with determinant +1 to `tolerance` (max
// |(R R^T - I)_ij| and |det - 1|); InputError naming `where` otherwise.
void RequireRotation(const Eigen::Matrix3d& rotation, double tolerance, const std::string& where);

// Rotation read from a file, printed with a limited number of digits: require it to be
// orthonormal with determinant +1 to `tolerance` (max |(R R^T - I)_ij| and |det - 1|),
// naming `where`, then return the nearest rotation (SVD projection) so that downstream
// code sees a rotation exact to machine precision.
Eigen::Matrix3d RequireNearRotation(const Eigen::Matrix3d& rotation, double tolerance,
                                    const std::string& where);

// Joins "file" and "field" into the `where` of an InputError: "file: field".
inline std::string Where(const std::string& file, const std::string& field) {
  return file + ": " + field;
}

}  // namespace dome::geometry::internal
