// Test helpers for the viewer: a small take and output folder made on disk, and a
// plain HTTP/1.1 GET over a TCP socket that sends the request target byte for byte
// (no client-side normalisation or encoding, so traversal attempts reach the server
// exactly as written).
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>

#include "geometry/rig.h"
#include "io/depth_tiff.h"
#include "io/ply.h"
#include "take/take.h"
#include "take_fixture.h"

namespace dome::view::testing {

// A flat square of side 2 * half_mm at height z_mm (two triangles), world mm.
inline io::Mesh Square(float half_mm, float z_mm) {
  io::Mesh m;
  m.vertices = {{-half_mm, -half_mm, z_mm},
                {half_mm, -half_mm, z_mm},
                {half_mm, half_mm, z_mm},
                {-half_mm, half_mm, z_mm}};
  m.faces = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

struct ViewFixture {
  std::filesystem::path take, out;
  std::vector<std::string> instants;  // the take's, in order
  geometry::Rig rig;
};

// TAKE: 4 ring cameras (64 x 48), 3 instants, a truth mesh (the square at z = 0) and
// a truth depth map for c0 at the first instant. OUT: the first instant has mesh.ply
// (square at z = 7 mm) and mesh_decimated.ply, the second only mesh.ply, the third
// nothing; plus a folder that is not an instant.
inline ViewFixture MakeViewFixture(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  ViewFixture f;
  f.rig = take::testing::MakeRingRig(4, 64, 48);
  f.take = take::testing::WriteTake(dir / "take", f.rig, 3);
  f.instants = take::OpenTake(f.take).instants;
  f.out = dir / "out";
  const std::string& i0 = f.instants[0];
  fs::create_directories(f.take / "truth" / i0 / "depth");
  io::WritePly(f.take / "truth" / i0 / "mesh.ply", Square(1000, 0));
  cv::Mat depth(48, 64, CV_32FC1, cv::Scalar(2000.0f));
  depth(cv::Rect(0, 0, 10, 48)).setTo(0.0f);
  io::WriteDepthTiff(f.take / "truth" / i0 / "depth" / "c0.tiff", depth);
  fs::create_directories(f.out / i0);
  fs::create_directories(f.out / f.instants[1]);
  fs::create_directories(f.out / "logs");
  io::WritePly(f.out / i0 / "mesh.ply", Square(500, 7));
  io::WritePly(f.out / i0 / "mesh_decimated.ply", Square(400, -3));
  io::WritePly(f.out / f.instants[1] / "mesh.ply", Square(500, 1));
  return f;
}

struct HttpReply {
  int status = 0;  // 0 when no reply could be read
  std::string body;
};

inline HttpReply RawGet(int port, const std::string& target) {
  HttpReply reply;
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return reply;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(uint16_t(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return reply;
  }
  const std::string request =
      "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
  if (::send(fd, request.data(), request.size(), 0) != ssize_t(request.size())) {
    ::close(fd);
    return reply;
  }
  std::string raw;
  char buf[65536];
  ssize_t n;
  while ((n = ::recv(fd, buf, sizeof buf, 0)) > 0) raw.append(buf, size_t(n));
  ::close(fd);
  const size_t head_end = raw.find("\r\n\r\n");
  if (raw.rfind("HTTP/1.1 ", 0) != 0 || head_end == std::string::npos) return reply;
  reply.status = std::stoi(raw.substr(9, 3));
  reply.body = raw.substr(head_end + 4);
  return reply;
}

}  // namespace dome::view::testing
