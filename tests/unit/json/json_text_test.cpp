// The tools' one JSON writer: strings that are always valid JSON and UTF-8, numbers that read
// back to the same value, and objects with their commas.
#include "tools/json/json_text.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <limits>
#include <string>

using namespace fieldline;

namespace {

std::string asJson(std::string_view text) {
  std::string out;
  json::appendString(out, text);
  return out;
}

}  // namespace

TEST(JsonString, EscapesQuotesBackslashesAndControlCharacters) {
  EXPECT_EQ(asJson("a\"b\\c"), R"("a\"b\\c")");
  EXPECT_EQ(asJson(std::string("\n\t\x01\x1f", 4)), R"("\n\t\u0001\u001f")");
  EXPECT_EQ(asJson(std::string("nul\0x", 5)), R"("nul\u0000x")");
  EXPECT_EQ(asJson(""), R"("")");
}

TEST(JsonString, KeepsValidUtf8) {
  EXPECT_EQ(asJson("µs ° 😀"), "\"µs ° 😀\"");
}

TEST(JsonString, ReplacesInvalidUtf8) {
  EXPECT_EQ(asJson("\xff"), R"("\ufffd")");
  EXPECT_EQ(asJson("\xc0\xaf"), R"("\ufffd\ufffd")");            // overlong '/'
  EXPECT_EQ(asJson("\xed\xa0\x80"), R"("\ufffd\ufffd\ufffd")");  // a surrogate
  EXPECT_EQ(asJson("ab\xe2\x82"), R"("ab\ufffd\ufffd")");        // cut sequence at the end
  EXPECT_EQ(asJson("\xf4\x90\x80\x80"), R"("\ufffd\ufffd\ufffd\ufffd")");  // past U+10FFFF
}

TEST(JsonNumber, NonFiniteNumbersBecomeNull) {
  std::string out;
  json::appendNumber(out, std::numeric_limits<double>::quiet_NaN());
  out += ',';
  json::appendNumber(out, -std::numeric_limits<double>::infinity());
  out += ',';
  json::appendNumber(out, std::numeric_limits<float>::infinity());
  out += ',';
  json::appendNumber(out, 1e-300);
  EXPECT_EQ(out, "null,null,null,1e-300");
}

TEST(JsonNumber, ReadsBackToTheSameValue) {
  for (const double value : {0.1, 1.0 / 3.0, -2.5e-7, 6.02214076e23}) {
    std::string out;
    json::appendNumber(out, value);
    EXPECT_EQ(std::strtod(out.c_str(), nullptr), value) << out;
  }
  std::string out;
  json::appendNumber(out, 0.1f);  // a float's own shortest form, not the double's 0.10000000149
  EXPECT_EQ(out, "0.1");
}

TEST(JsonObject, PutsCommasBetweenMembersAndNests) {
  std::string out;
  {
    json::Object o(out);
    o.integer("seq", -3);
    o.boolean("ok", true);
    o.string("name", "a\"b");
    const float xs[] = {1.5f, 2.0f};
    o.numbers("xs", xs, 2);
    json::Object inner(o.key("inner"));
    inner.number("nan", std::numeric_limits<double>::quiet_NaN());
  }
  EXPECT_EQ(out, R"({"seq":-3,"ok":true,"name":"a\"b","xs":[1.5,2],"inner":{"nan":null}})");
}
