// Envelopes, the blob cache and content hashes.
#include "net/wire.h"

#include <gtest/gtest.h>

#include <chrono>

#include "net/blob_cache.h"
#include "net/content_hash.h"
#include "testing/expect_error.h"

namespace dome::net {
namespace {

TEST(Wire, RoundTripAndRefusals) {
  runtime::Envelope env;
  env.mutable_hello()->set_threads(3);
  const std::string bytes = EncodeEnvelope(env);
  const runtime::Envelope back = DecodeEnvelope(bytes, "peer x", 1 << 20);
  EXPECT_EQ(back.version(), kProtocolVersion);
  EXPECT_EQ(back.hello().threads(), 3);

  testing::ExpectInputError([&] { DecodeEnvelope(bytes, "peer x", 4); },
                            {"peer x", "over the cap of 4"});
  testing::ExpectInputError([&] { DecodeEnvelope("\xff\xff\xff", "peer y", 1 << 20); },
                            {"peer y", "not a dome runtime envelope"});
  runtime::Envelope other = env;
  other.set_version(kProtocolVersion + 6);
  std::string other_bytes;
  other.SerializeToString(&other_bytes);
  testing::ExpectInputError([&] { DecodeEnvelope(other_bytes, "peer z", 1 << 20); },
                            {"peer z", "protocol version " + std::to_string(kProtocolVersion + 6),
                             "this side speaks version " + std::to_string(kProtocolVersion)});
  runtime::Envelope empty;
  testing::ExpectInputError([&] { DecodeEnvelope(EncodeEnvelope(empty), "p", 1 << 20); },
                            {"without a message body"});
  EXPECT_EQ(PeerName(std::string("\x00\x80\x01", 3)), "peer 0x008001");
  // Capture agents name their sockets by camera: shown as text.
  EXPECT_EQ(PeerName("c07"), "peer c07");
  EXPECT_EQ(PeerName(""), "peer 0x");
}

// One receive for every socket: all parts of a message, nothing when none waits.
// Text that is not UTF-8 (a Linux path may be any bytes) crosses the wire unchanged.
TEST(Wire, BytesThatAreNotUtf8CrossTheWireUnchanged) {
  // Valid UTF-8 passes through as it is.
  for (const std::string text : {"", "plain", "caf\xC3\xA9 \xE2\x82\xAC \xF0\x9F\x8E\xA5"}) {
    EXPECT_EQ(EscapeUtf8(text), text);
    EXPECT_EQ(UnescapeUtf8(text), text);
  }
  // Every byte value, lone continuation bytes, truncated, overlong and surrogate
  // sequences, and the escapes' own code points: escaped to valid UTF-8, then back.
  std::string all;
  for (int b = 0; b < 256; ++b) all.push_back(char(b));
  for (const std::string& text :
       {all, std::string("take\xE9"), std::string("\xC0\xAF"), std::string("\xED\xA0\x80"),
        std::string("\xE2\x82"), std::string("\xF4\x8F\xBC\x80 literal"),
        std::string("\xF4\x90\x80\x80")}) {
    const std::string escaped = EscapeUtf8(text);
    runtime::Envelope probe;
    probe.mutable_refusal()->set_reason(escaped);
    std::string bytes;
    ASSERT_TRUE(probe.SerializeToString(&bytes));
    runtime::Envelope parsed;
    EXPECT_TRUE(parsed.ParseFromString(bytes)) << "escaped text is valid UTF-8";
    EXPECT_EQ(UnescapeUtf8(escaped), text);
  }
  // Through a whole envelope: a session whose take folder has byte 0xE9 in its name.
  runtime::Envelope env;
  auto* session = env.mutable_control()->mutable_submit()->mutable_session();
  session->set_take("/data/take\xE9");
  session->add_instants("00-00-00-\xFF");
  const runtime::Envelope back = DecodeEnvelope(EncodeEnvelope(env), "test", 1 << 20);
  EXPECT_EQ(back.control().submit().session().take(), "/data/take\xE9");
  EXPECT_EQ(back.control().submit().session().instants(0), "00-00-00-\xFF");
}

TEST(Wire, ReceiveFramesTakesEveryPartOfOneMessage) {
  zmq::context_t context;
  zmq::socket_t a(context, zmq::socket_type::pair), b(context, zmq::socket_type::pair);
  a.bind("inproc://wire-test");
  b.connect("inproc://wire-test");
  EXPECT_TRUE(ReceiveFrames(&b).empty());
  EXPECT_FALSE(WaitForInput(&b, 1));
  ASSERT_TRUE(SendFrames(&a, {"one", "", "three"}));
  ASSERT_TRUE(SendFrames(&a, {"next"}));
  ASSERT_TRUE(WaitForInput(&b, 1000));
  const auto first = ReceiveFrames(&b);
  ASSERT_EQ(first.size(), 3u);
  EXPECT_EQ(first[0].to_string(), "one");
  EXPECT_EQ(first[1].size(), 0u);
  EXPECT_EQ(first[2].to_string(), "three");
  const auto second = ReceiveFrames(&b);
  ASSERT_EQ(second.size(), 1u);
  EXPECT_EQ(second[0].to_string(), "next");
}

// A socket that cannot take a message (here: "immediate" and no peer to connect to) makes
// SendWithin give up at its limit, where a send without one would wait for good; the
// socket's own send time-out is as it was afterwards.
TEST(Wire, SendWithinGivesUpAtItsLimit) {
  zmq::context_t context;
  zmq::socket_t req(context, zmq::socket_type::req);
  req.set(zmq::sockopt::linger, 0);
  req.set(zmq::sockopt::immediate, 1);
  req.connect("tcp://127.0.0.1:1");
  const auto start = std::chrono::steady_clock::now();
  EXPECT_FALSE(SendWithin(&req, "request", 200));
  const double waited_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_GE(waited_s, 0.18);
  EXPECT_LT(waited_s, 5.0);
  EXPECT_EQ(req.get(zmq::sockopt::sndtimeo), -1);
  // A socket that can take it sends at once.
  zmq::socket_t a(context, zmq::socket_type::pair), b(context, zmq::socket_type::pair);
  a.bind("inproc://send-within");
  b.connect("inproc://send-within");
  EXPECT_TRUE(SendWithin(&a, "hello", 200));
  ASSERT_TRUE(WaitForInput(&b, 1000));
  EXPECT_EQ(ReceiveFrames(&b)[0].to_string(), "hello");
}

TEST(BlobCache, EvictsLeastRecentlyUsedWithinTheBound) {
  BlobCache cache(10);
  auto blob = [](int n) { return std::make_shared<const std::string>(size_t(n), 'x'); };
  cache.Put("a", blob(4));
  cache.Put("b", blob(4));
  EXPECT_NE(cache.Get("a"), nullptr);  // a is now more recent than b
  cache.Put("c", blob(4));             // 12 > 10: b goes
  EXPECT_EQ(cache.Get("b"), nullptr);
  EXPECT_NE(cache.Get("a"), nullptr);
  EXPECT_NE(cache.Get("c"), nullptr);
  EXPECT_EQ(cache.bytes(), 8);
  cache.Put("huge", blob(11));  // over the bound: not kept, nothing evicted
  EXPECT_EQ(cache.Get("huge"), nullptr);
  EXPECT_EQ(cache.size(), 2u);
}

TEST(ContentHash, Sha256OfKnownVectors) {
  // FIPS 180-4 examples.
  EXPECT_EQ(net::Sha256Hex("abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(net::Sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_TRUE(net::IsSha256Hex(net::Sha256Hex("x")));
  EXPECT_FALSE(net::IsSha256Hex("../etc/passwd"));
}

}  // namespace
}  // namespace dome::net
