#include "nerfreg/util/zip_reader.h"

#include <gtest/gtest.h>

#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// Overwrites a little-endian uint32 of the first central directory record.
void PatchCentral(std::string* zip, size_t field_offset, std::uint32_t value) {
  const size_t at = zip->find(std::string("PK\x01\x02", 4));
  ASSERT_NE(at, std::string::npos);
  for (int k = 0; k < 4; ++k) (*zip)[at + field_offset + k] = static_cast<char>((value >> (8 * k)) & 0xff);
}

TEST(ZipReader, ReadsStoredAndDeflatedEntriesFromFileAndMemory) {
  const std::string text(5000, 'x');
  const std::string zip = MakeTestZip({{"a/model.obj", "v 0 0 0\n", false}, {"a/big.txt", text + "end", true}});
  ScopedTempDir dir;
  WriteFileAtomic(dir.File("f.zip"), zip);
  for (const ZipReader& z : {ZipReader::Open(dir.File("f.zip")), ZipReader::FromBytes(zip, "mem.zip")}) {
    ASSERT_EQ(z.entries().size(), 2u);
    EXPECT_EQ(z.entries()[1].method, 8);
    EXPECT_LT(z.entries()[1].compressed, 200);
    EXPECT_TRUE(z.Has("a/model.obj"));
    EXPECT_FALSE(z.Has("a/none.obj"));
    EXPECT_EQ(z.Read("a/model.obj"), "v 0 0 0\n");
    EXPECT_EQ(z.Read("a/big.txt"), text + "end");
    EXPECT_NE(InputErrorOf([&] { z.Read("a/none.obj"); }).find("a/none.obj"), std::string::npos);
  }
}

TEST(ZipReader, RefusesTraversalAbsoluteAndBackslashNames) {
  for (const std::string name : {"../evil.txt", "a/../../evil.txt", "/etc/passwd", "C:/x.txt", "a\\..\\x"}) {
    const std::string zip = MakeTestZip({{"ok.txt", "1", false}, {name, "2", false}});
    const std::string error = InputErrorOf([&] { ZipReader::FromBytes(zip, "bad.zip"); });
    EXPECT_NE(error.find("bad.zip: entry \"" + name + "\""), std::string::npos) << error;
  }
}

TEST(ZipReader, RefusesOversizeEntriesAndLiesAboutSize) {
  const std::string zip = MakeTestZip({{"bomb.txt", std::string(100000, 'a'), true}});
  ZipLimits limits;
  limits.max_entry_bytes = 50000;
  EXPECT_NE(InputErrorOf([&] { ZipReader::FromBytes(zip, "z.zip", limits); }).find("at most 50000 bytes uncompressed"),
            std::string::npos);
  limits = ZipLimits();
  limits.max_total_bytes = 1000;
  EXPECT_NE(InputErrorOf([&] { ZipReader::FromBytes(zip, "z.zip", limits); }).find("in all"), std::string::npos);
  // A bomb that declares a small size: inflation stops at the declared size and the entry fails.
  std::string lying = zip;
  PatchCentral(&lying, 24, 100);
  const ZipReader z = ZipReader::FromBytes(lying, "z.zip");
  EXPECT_NE(InputErrorOf([&] { z.Read("bomb.txt"); }).find("inflating past its size"), std::string::npos);
}

TEST(ZipReader, RefusesCorruptArchives) {
  std::string zip = MakeTestZip({{"a.txt", "hello", false}});
  std::string flipped = zip;
  flipped[30 + 5] = 'j';  // the stored data, after the 30-byte local header and the name
  const ZipReader z = ZipReader::FromBytes(flipped, "z.zip");
  EXPECT_NE(InputErrorOf([&] { z.Read("a.txt"); }).find("CRC-32"), std::string::npos);
  EXPECT_NE(InputErrorOf([&] {
              ZipReader::FromBytes("not a zip at all, longer than 22 bytes", "n.zip");
            }).find("n.zip: expected a zip archive"),
            std::string::npos);
  EXPECT_NE(InputErrorOf([&] { ZipReader::FromBytes(zip.substr(0, zip.size() - 30), "t.zip"); }), "");
}

TEST(ZipReader, ResolvesPathsInsideTheArchiveOnly) {
  EXPECT_EQ(ResolveArchivePath("a/b/", "tex.png"), "a/b/tex.png");
  EXPECT_EQ(ResolveArchivePath("a/b/", "../t/tex.png"), "a/t/tex.png");
  EXPECT_EQ(ResolveArchivePath("a/b/", ".\\t\\tex.png"), "a/b/t/tex.png");
  EXPECT_EQ(ResolveArchivePath("a/", "../../tex.png"), "");
  EXPECT_EQ(ResolveArchivePath("a/", "/etc/passwd"), "");
  EXPECT_EQ(ResolveArchivePath("a/", "C:/Documents and Settings/x.jpg"), "");
}

}  // namespace
}  // namespace nerfreg
