// The full lookup table (issue 12, part 1): written and read back cell for cell, from a stream
// and through a colour preset's `lookup_table` key; damaged files are refused with the reason;
// boxes over a lookup table's other classes.
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "common/camera/colour.hpp"

namespace fieldline::camera {
namespace colour_lookup_test {

ColourTable boxTable() {
  return ColourTable({
      {ColourClass::kGreen, {50, 120}, {100, 124}, {100, 124}},
      {ColourClass::kWhite, {170, 255}, {116, 140}, {116, 140}},
      {ColourClass::kOrange, {60, 200}, {60, 110}, {160, 230}},
      {ColourClass::kBlack, {0, 40}, {0, 255}, {0, 255}},
  });
}

std::string written(const ColourTable& table) {
  std::ostringstream out;
  writeColourLookup(out, table);
  return out.str();
}

ColourTable readBack(const std::string& bytes) {
  std::istringstream in(bytes);
  return readColourLookup(in, "test.lut");
}

TEST(ColourLookup, ATableReadsBackCellForCellAndClassifiesTheSame) {
  const ColourTable boxes = boxTable();
  const std::string bytes = written(boxes);
  EXPECT_EQ(bytes.rfind("fieldline-colour-lut 1\nbits 6\n", 0), 0u);
  EXPECT_LT(bytes.size(), 100000u);
  const ColourTable back = readBack(bytes);
  EXPECT_TRUE(back.fromLookupTable());
  EXPECT_EQ(back.yuvLookup(), boxes.yuvLookup());
  EXPECT_EQ(back.classifyYuv(90, 112, 110), ColourClass::kGreen);
  EXPECT_EQ(back.classifyExact({90, 112, 110}), ColourClass::kGreen);
  EXPECT_EQ(back.classifyBgr(bgrFromYuv({120, 80, 200})), ColourClass::kOrange);
  // Written again, the same bytes.
  EXPECT_EQ(written(back), bytes);
}

TEST(ColourLookup, DamagedFilesAreRefusedWithTheReason) {
  const std::string bytes = written(boxTable());
  auto refusal = [](const std::string& b) {
    try {
      (void)readBack(b);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refusal("hello\n").find("not a colour lookup table"), std::string::npos);
  std::string bits = bytes;
  bits.replace(bits.find("bits 6"), 6, "bits 5");
  EXPECT_NE(refusal(bits).find("bits 6"), std::string::npos);
  EXPECT_NE(refusal(bytes.substr(0, bytes.size() - 3)).find("run"), std::string::npos)
      << refusal(bytes.substr(0, bytes.size() - 3));
  EXPECT_NE(refusal(bytes + "x").find("bytes after the last run"), std::string::npos);
  std::string classes = bytes;
  classes.replace(classes.find("green"), 5, "gruen");
  EXPECT_NE(refusal(classes).find("unknown class 'gruen'"), std::string::npos);
  EXPECT_THROW((void)ColourTable::fromLookup(std::vector<ColourClass>(10)), std::invalid_argument);
}

TEST(ColourLookup, APresetNamesItsLookupFileAndBoxesGoOverALookupTable) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("colour_lookup_test_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  writeColourLookupFile((dir / "venue.lut").string(), boxTable());
  {
    std::ofstream yaml(dir / "venue.yaml");
    yaml << "lookup_table: venue.lut\n";
  }
  const ColourTable loaded = loadColourTablePreset((dir / "venue.yaml").string());
  EXPECT_EQ(loaded.yuvLookup(), boxTable().yuvLookup());
  {
    std::ofstream yaml(dir / "both.yaml");
    yaml << "lookup_table: venue.lut\ncolours:\n  green:\n    - {y: [0, 10], u: [0, 10], v: [0, "
            "10]}\n";
    std::ofstream missing(dir / "missing.yaml");
    missing << "lookup_table: nowhere.lut\n";
  }
  EXPECT_THROW((void)loadColourTablePreset((dir / "both.yaml").string()), config::Error);
  EXPECT_THROW((void)loadColourTablePreset((dir / "missing.yaml").string()), config::Error);

  // New green over the lookup table: green where the box says, the rest from the lookup table.
  const ColourTable over({{ColourClass::kGreen, {20, 49}, {100, 124}, {100, 124}}}, loaded);
  EXPECT_EQ(over.classifyYuv(30, 112, 110), ColourClass::kGreen);
  EXPECT_EQ(over.classifyYuv(90, 112, 110), ColourClass::kGreen);
  EXPECT_EQ(over.classifyYuv(120, 80, 200), ColourClass::kOrange);
  EXPECT_EQ(over.classifyYuv(10, 200, 10), ColourClass::kBlack);
  std::filesystem::remove_all(dir);
}

}  // namespace colour_lookup_test
}  // namespace fieldline::camera
