// Serial protocol: encoding, COBS, and a decoder that never yields a wrong frame and always
// resynchronises, under random bytes, truncation and bit flips.
#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <boost/crc.hpp>

#include "common/serial/protocol.hpp"

namespace fieldline::serial {
namespace protocol_test {

using Bytes = std::vector<std::uint8_t>;

Message randomMessage(std::mt19937& rng) {
  std::uniform_int_distribution<std::uint32_t> u32;
  std::uniform_int_distribution<int> i16(-32767, 32767);
  switch (rng() % 4) {
    case 0:
      return Hello{rng() % 2 ? Role::kHost : Role::kController,
                   static_cast<std::uint16_t>(u32(rng)), static_cast<std::uint16_t>(u32(rng)),
                   u32(rng)};
    case 1:
      return VelocityCommand{u32(rng), static_cast<std::int16_t>(i16(rng)),
                             static_cast<std::int16_t>(i16(rng)),
                             static_cast<std::int16_t>(i16(rng))};
    case 2: {
      OdometrySample s;
      s.seq = u32(rng);
      s.controller_time_us = (static_cast<std::uint64_t>(u32(rng)) << 32) | u32(rng);
      // Three wheels (type 0x20) or four (0x21).
      const std::size_t wheels = rng() % 2 ? 3 : 4;
      s.ticks.clear();
      for (std::size_t i = 0; i < wheels; ++i)
        s.ticks.push_back(static_cast<std::int32_t>(u32(rng)));
      s.status = static_cast<std::uint16_t>(u32(rng));
      s.last_command_seq = u32(rng);
      // Half the samples carry wheel currents (the 36-byte body with three wheels).
      if (rng() % 2) {
        PerWheel<std::int16_t> current;
        for (std::size_t i = 0; i < wheels; ++i)
          current.push_back(static_cast<std::int16_t>(i16(rng)));
        s.current_ma = current;
      }
      // Half carry the gyro's angle (34 or 40 bytes with the currents).
      if (rng() % 2) s.gyro_angle_urad = static_cast<std::int32_t>(u32(rng));
      return s;
    }
    default:
      return ErrorReport{static_cast<ErrorCode>(1 + rng() % 3), u32(rng)};
  }
}

std::vector<Message> decodeAll(const Bytes& stream, Decoder& decoder, std::mt19937* rng = nullptr) {
  std::vector<Message> out;
  std::size_t pos = 0;
  while (pos < stream.size()) {
    // Feed in random pieces when asked: the decoder must not care where reads split the stream.
    const std::size_t piece = rng ? 1 + (*rng)() % 40 : stream.size();
    const std::size_t n = std::min(piece, stream.size() - pos);
    decoder.feed(std::span(stream).subspan(pos, n), out);
    pos += n;
  }
  return out;
}

// A payload with a correct CRC, for frames that are well-formed but semantically wrong.
Bytes frameFromPayload(Bytes payload) {
  boost::crc_32_type crc;
  crc.process_bytes(payload.data(), payload.size());
  const std::uint32_t c = crc.checksum();
  for (int i = 0; i < 4; ++i)
    payload.push_back(static_cast<std::uint8_t>(c >> (8 * i)));
  Bytes out;
  cobsEncode(payload, out);
  out.push_back(0);
  return out;
}

TEST(Cobs, KnownVectors) {
  const auto enc = [](const Bytes& in) {
    Bytes out;
    cobsEncode(in, out);
    return out;
  };
  EXPECT_EQ(enc({0x00}), (Bytes{0x01, 0x01}));
  EXPECT_EQ(enc({0x00, 0x00}), (Bytes{0x01, 0x01, 0x01}));
  EXPECT_EQ(enc({0x11, 0x22, 0x00, 0x33}), (Bytes{0x03, 0x11, 0x22, 0x02, 0x33}));
  EXPECT_EQ(enc({0x11, 0x22, 0x33, 0x44}), (Bytes{0x05, 0x11, 0x22, 0x33, 0x44}));
  EXPECT_EQ(enc({0x11, 0x00, 0x00, 0x00}), (Bytes{0x02, 0x11, 0x01, 0x01, 0x01}));
  Bytes back;
  EXPECT_FALSE(cobsDecode(Bytes{0x05, 0x11, 0x22}, back));  // run past the end
  EXPECT_FALSE(cobsDecode(Bytes{0x02, 0x00}, back));        // a zero inside a frame
}

TEST(Cobs, RoundTripOfRandomData) {
  std::mt19937 rng(3);
  for (std::size_t len = 0; len < 700; ++len) {
    Bytes data(len);
    for (auto& b : data)
      b = static_cast<std::uint8_t>(rng() % 4 == 0 ? 0 : rng());
    Bytes enc;
    cobsEncode(data, enc);
    EXPECT_EQ(std::count(enc.begin(), enc.end(), 0), 0);
    EXPECT_LE(enc.size(), len + len / 254 + 1);
    Bytes dec;
    ASSERT_TRUE(cobsDecode(enc, dec));
    EXPECT_EQ(dec, data);
  }
}

TEST(Protocol, Q15Conversion) {
  EXPECT_EQ(toQ15(1.0), 32767);
  EXPECT_EQ(toQ15(-1.0), -32767);
  EXPECT_EQ(toQ15(2.5), 32767);
  EXPECT_EQ(toQ15(0.5), 16384);
  EXPECT_EQ(toQ15(std::nan("")), 0);
  EXPECT_NEAR(fromQ15(toQ15(0.123)), 0.123, 1.0 / 32767);
  EXPECT_DOUBLE_EQ(fromQ15(-32768), -1.0);
}

TEST(Protocol, HandEncodedVelocityCommandIsLittleEndian) {
  const Bytes frame = encode(VelocityCommand{0x04030201, 0x0605, -2, 0x0a09});
  Bytes payload;
  ASSERT_EQ(frame.back(), 0);
  ASSERT_TRUE(cobsDecode(std::span(frame).first(frame.size() - 1), payload));
  const Bytes expected_head{kVersion, 0x10, 0x01, 0x02, 0x03, 0x04,
                            0x05,     0x06, 0xfe, 0xff, 0x09, 0x0a};
  ASSERT_EQ(payload.size(), expected_head.size() + 4);
  EXPECT_TRUE(std::equal(expected_head.begin(), expected_head.end(), payload.begin()));
  EXPECT_LE(frame.size(), kMaxFrameSize);
}

TEST(Protocol, EveryTypeRoundTrips) {
  std::mt19937 rng(5);
  for (int i = 0; i < 2000; ++i) {
    const Message m = randomMessage(rng);
    const Bytes frame = encode(m);
    EXPECT_LE(frame.size(), kMaxFrameSize);
    EXPECT_EQ(std::count(frame.begin(), frame.end(), 0), 1);
    Decoder d;
    std::vector<Message> out;
    ASSERT_EQ(d.feed(frame, out), 1u);
    EXPECT_EQ(out.front(), m);
  }
}

TEST(Protocol, OdometryCarriesCurrentsInAnOptionalTail) {
  OdometrySample s;
  s.seq = 3;
  s.ticks = {1, 2, 3};
  const Bytes plain = encode(s);
  s.current_ma = PerWheel<std::int16_t>{1500, -32767, 7};
  const Bytes with = encode(s);
  // COBS adds nothing here: no run reaches 254 bytes. 6 more bytes for the three currents.
  EXPECT_EQ(with.size(), plain.size() + 6);
  Decoder d;
  std::vector<Message> out;
  d.feed(plain, out);
  d.feed(with, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_FALSE(std::get<OdometrySample>(out[0]).current_ma);
  EXPECT_EQ(std::get<OdometrySample>(out[1]), s);
  // Any other body length is refused: 30 + 2 bytes (one current) is neither layout.
  Bytes payload{kVersion, 0x20};
  payload.resize(2 + 32, 0);
  d.feed(frameFromPayload(payload), out);
  EXPECT_EQ(d.stats().length_errors, 1u);
  EXPECT_EQ(out.size(), 2u);
}

TEST(Protocol, OdometryCarriesTheGyroAngleInATailAfterTheCurrents) {
  OdometrySample s;
  s.seq = 9;
  s.controller_time_us = 123'456;
  s.ticks = {-4, 5, 6};
  s.status = kStatusReset;
  s.last_command_seq = 2;
  const Bytes plain = encode(s);
  s.gyro_angle_urad = -2'000'000'123;
  const Bytes gyro_only = encode(s);
  s.current_ma = PerWheel<std::int16_t>{-1, 0, 1};
  const Bytes both = encode(s);
  EXPECT_EQ(gyro_only.size(), plain.size() + 4);
  EXPECT_EQ(both.size(), plain.size() + 10);

  // The 30-byte body of a controller without either tail, written by hand as an old firmware
  // sends it: still decoded, with neither tail.
  Bytes old_payload{kVersion, 0x20};
  const auto le = [&](std::uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i)
      old_payload.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  };
  le(9, 4);
  le(123'456, 8);
  le(static_cast<std::uint32_t>(-4), 4);
  le(5, 4);
  le(6, 4);
  le(kStatusReset, 2);
  le(2, 4);
  ASSERT_EQ(old_payload.size(), 2u + 30u);
  EXPECT_EQ(frameFromPayload(old_payload), plain);

  Decoder d;
  std::vector<Message> out;
  d.feed(frameFromPayload(old_payload), out);
  d.feed(gyro_only, out);
  d.feed(both, out);
  ASSERT_EQ(out.size(), 3u);
  const auto& old_sample = std::get<OdometrySample>(out[0]);
  EXPECT_FALSE(old_sample.gyro_angle_urad);
  EXPECT_FALSE(old_sample.current_ma);
  EXPECT_EQ(old_sample.ticks, (PerWheel<std::int32_t>{-4, 5, 6}));
  const auto& g = std::get<OdometrySample>(out[1]);
  ASSERT_TRUE(g.gyro_angle_urad);
  EXPECT_EQ(*g.gyro_angle_urad, -2'000'000'123);
  EXPECT_FALSE(g.current_ma);
  EXPECT_EQ(std::get<OdometrySample>(out[2]), s);
  // Lengths of no layout (30 + 2, 30 + 8) are refused and counted.
  for (std::size_t body : {32u, 38u}) {
    Bytes payload{kVersion, 0x20};
    payload.resize(2 + body, 0);
    d.feed(frameFromPayload(payload), out);
  }
  EXPECT_EQ(d.stats().length_errors, 2u);
  EXPECT_EQ(out.size(), 3u);
}

TEST(Protocol, FourWheelsGoOutAsType0x21WithTheirCount) {
  OdometrySample s;
  s.seq = 0x01020304;
  s.controller_time_us = 0x1122334455;
  s.ticks = {-1, 2, -3, 4};
  s.status = kStatusWatchdog;
  s.last_command_seq = 9;
  const Bytes plain = encode(s);
  // Written by hand: seq, time, the count 4, four ticks, status, last command.
  Bytes payload{kVersion, 0x21};
  const auto le = [&](std::uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i)
      payload.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  };
  le(0x01020304, 4);
  le(0x1122334455, 8);
  le(4, 1);
  for (const std::int32_t t : {-1, 2, -3, 4})
    le(static_cast<std::uint32_t>(t), 4);
  le(kStatusWatchdog, 2);
  le(9, 4);
  ASSERT_EQ(payload.size(), 2u + 35u);
  EXPECT_EQ(frameFromPayload(payload), plain);

  s.current_ma = PerWheel<std::int16_t>{100, -200, 300, -400};
  const Bytes currents = encode(s);
  s.gyro_angle_urad = 77;
  const Bytes both = encode(s);
  EXPECT_EQ(currents.size(), plain.size() + 8);
  EXPECT_EQ(both.size(), plain.size() + 12);
  ASSERT_LE(both.size(), kMaxFrameSize);
  Decoder d;
  std::vector<Message> out;
  d.feed(plain, out);
  d.feed(currents, out);
  d.feed(both, out);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(std::get<OdometrySample>(out[0]).ticks.size(), 4u);
  EXPECT_EQ(std::get<OdometrySample>(out[1]).current_ma->size(), 4u);
  EXPECT_EQ(std::get<OdometrySample>(out[2]), s);

  // Three wheels in the counted form (a controller that always sends 0x21) decode too.
  Bytes three{kVersion, 0x21};
  three.insert(three.end(), payload.begin() + 2, payload.begin() + 2 + 12);
  three.push_back(3);
  three.insert(three.end(), payload.begin() + 2 + 13, payload.begin() + 2 + 25);
  three.insert(three.end(), payload.end() - 6, payload.end());
  d.feed(frameFromPayload(three), out);
  ASSERT_EQ(out.size(), 4u);
  EXPECT_EQ(std::get<OdometrySample>(out[3]).ticks, (PerWheel<std::int32_t>{-1, 2, -3}));
  // Counts outside 3..4, and a body whose length fits no layout for its count, are refused.
  for (std::uint8_t count : {0, 2, 5, 255}) {
    Bytes bad = payload;
    bad[2 + 12] = count;
    d.feed(frameFromPayload(bad), out);
  }
  Bytes short_one = payload;
  short_one.pop_back();
  d.feed(frameFromPayload(short_one), out);
  EXPECT_EQ(d.stats().length_errors, 5u);
  EXPECT_EQ(out.size(), 4u);
  // A sample without 3 or 4 ticks, or with currents for another count, cannot be encoded.
  OdometrySample two;
  two.ticks = {1, 2};
  EXPECT_THROW(encode(two), std::invalid_argument);
  OdometrySample mismatch;
  mismatch.ticks = {1, 2, 3, 4};
  mismatch.current_ma = PerWheel<std::int16_t>{1, 2, 3};
  EXPECT_THROW(encode(mismatch), std::invalid_argument);
}

TEST(Protocol, WellFormedButWrongFramesAreCountedByReason) {
  Decoder d;
  std::vector<Message> out;
  // Right CRC, wrong version.
  d.feed(frameFromPayload({2, 0x10, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0}), out);
  EXPECT_EQ(d.stats().version_errors, 1u);
  // Unknown type.
  d.feed(frameFromPayload({kVersion, 0x77, 1, 2, 3}), out);
  EXPECT_EQ(d.stats().unknown_type_errors, 1u);
  // Velocity command one byte short.
  d.feed(frameFromPayload({kVersion, 0x10, 0, 0, 0, 0, 0, 0, 0, 0, 0}), out);
  EXPECT_EQ(d.stats().length_errors, 1u);
  // Too short to hold a CRC.
  d.feed(Bytes{0x02, 0x01, 0x00}, out);
  EXPECT_EQ(d.stats().length_errors, 2u);
  // Hello with an undefined role.
  d.feed(frameFromPayload({kVersion, 0x01, 9, 0, 0, 0, 0, 0, 0, 0, 0}), out);
  EXPECT_EQ(d.stats().length_errors, 3u);
  // A long run without delimiter, then a valid frame after a delimiter.
  Bytes junk(200, 0x55);
  junk.push_back(0);
  d.feed(junk, out);
  EXPECT_EQ(d.stats().oversize_errors, 1u);
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(d.stats().badFrames(), 6u);
  // Idle delimiters are not errors.
  d.feed(Bytes{0, 0, 0}, out);
  EXPECT_EQ(d.stats().badFrames(), 6u);
  d.feed(encode(VelocityCommand{7, 1, 2, 3}), out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(std::get<VelocityCommand>(out[0]).seq, 7u);
  EXPECT_EQ(rejectName(d.lastReject()), "serial_oversize");
}

TEST(ProtocolFuzz, RandomBytesNeverDecode) {
  std::mt19937 rng(17);
  for (const int zero_every : {4, 16, 40, 256}) {
    Bytes noise(1 << 20);
    for (auto& b : noise)
      b = static_cast<std::uint8_t>(rng() % zero_every == 0 ? 0 : 1 + rng() % 255);
    Decoder d;
    EXPECT_TRUE(decodeAll(noise, d, &rng).empty()) << "zero every " << zero_every;
    EXPECT_GT(d.stats().badFrames(), 0u);
    EXPECT_EQ(d.stats().frames_ok, 0u);
  }
}

// A stream of intact frames mixed with garbage, truncated frames and frames with flipped,
// dropped or inserted bytes. Every intact frame right after a delimiter must come out (so at
// most the one frame a corruption merges with is lost), and whatever comes out must be a message
// that was sent, in order: a corrupted frame may only decode to its own original (a zero
// inserted before it just adds a delimiter), never to anything else.
TEST(ProtocolFuzz, CorruptionNeverYieldsAWrongFrameAndAlwaysResynchronises) {
  std::mt19937 rng(2024);
  Bytes stream;
  std::vector<Message> sent;
  std::vector<bool> guaranteed;
  std::size_t corruptions = 0;
  std::size_t intact = 0;
  for (int segment = 0; segment < 20000; ++segment) {
    const Message m = randomMessage(rng);
    Bytes frame = encode(m);
    const int kind = static_cast<int>(rng() % 10);
    sent.push_back(m);
    guaranteed.push_back(false);
    if (kind < 5) {
      // Intact: guaranteed when the previous byte is a delimiter (or at the very start).
      guaranteed.back() = stream.empty() || stream.back() == 0;
      ++intact;
    } else if (kind == 5) {
      const std::size_t n = 1 + rng() % 60;
      for (std::size_t i = 0; i < n; ++i)
        frame.push_back(static_cast<std::uint8_t>(rng()));
      frame.erase(frame.begin(), frame.begin() + static_cast<long>(frame.size() - n));
      ++corruptions;
    } else if (kind == 6) {
      frame.resize(1 + rng() % (frame.size() - 1));  // truncated, delimiter lost
      ++corruptions;
    } else if (kind == 7) {
      const int flips = 1 + static_cast<int>(rng() % 3);
      for (int f = 0; f < flips; ++f)
        frame[rng() % frame.size()] ^= 1u << (rng() % 8);
      ++corruptions;
    } else if (kind == 8) {
      frame.erase(frame.begin() + static_cast<long>(rng() % frame.size()));
      ++corruptions;
    } else {
      frame.insert(frame.begin() + static_cast<long>(rng() % frame.size()),
                   static_cast<std::uint8_t>(rng()));
      ++corruptions;
    }
    stream.insert(stream.end(), frame.begin(), frame.end());
  }
  Decoder d;
  const auto decoded = decodeAll(stream, d, &rng);
  std::size_t next = 0;
  std::size_t guaranteed_seen = 0;
  for (std::size_t i = 0; i < decoded.size(); ++i) {
    while (next < sent.size() && !(sent[next] == decoded[i])) {
      ASSERT_FALSE(guaranteed[next]) << "intact frame " << next << " was not decoded";
      ++next;
    }
    ASSERT_LT(next, sent.size()) << "decoded message " << i << " was never sent";
    guaranteed_seen += guaranteed[next] ? 1 : 0;
    ++next;
  }
  while (next < sent.size())
    ASSERT_FALSE(guaranteed[next++]);
  const auto guaranteed_total =
      static_cast<std::size_t>(std::count(guaranteed.begin(), guaranteed.end(), true));
  EXPECT_EQ(guaranteed_seen, guaranteed_total);
  // The test exercised what it claims: plenty of both, and most intact frames got through.
  EXPECT_GT(corruptions, 8000u);
  EXPECT_GT(d.stats().badFrames(), 5000u);
  EXPECT_GT(guaranteed_total, intact * 6 / 10);
  EXPECT_LT(decoded.size(), guaranteed_total + 20);
  EXPECT_EQ(d.stats().frames_ok, decoded.size());
}

}  // namespace protocol_test
}  // namespace fieldline::serial
