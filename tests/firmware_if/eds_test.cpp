// firmware_if/eds.hpp: the CiA 306 EDS reader, on small EDS texts written here. Expected
// values are read off the texts by hand; each malformation's line is found in the text
// itself (line_of), not taken from the reader.
#include "firmware_if/eds.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace dualv::fw::eds {
namespace {

// 1-based line of the first occurrence of `marker` in `text`.
int line_of(const std::string& text, const std::string& marker) {
  const std::size_t at = text.find(marker);
  EXPECT_NE(at, std::string::npos) << marker;
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
}

const std::string kLists = R"([FileInfo]
FileName=small.eds
; a comment
[DeviceInfo]
VendorName=Nobody

[MandatoryObjects]
SupportedObjects=2
1=0x1000
2=0x1018

[OptionalObjects]
SupportedObjects=3
1=0x1400
2=0x6071
3=0x6502
)";

const std::string kObjects = R"(
[1000]
ParameterName=Device type
ObjectType=0x7
DataType=0x0007
AccessType=ro
DefaultValue=0x00020192
PDOMapping=0

[1018]
ParameterName=Identity object
ObjectType=0x9
SubNumber=3

[1018sub0]
ParameterName=Highest sub-index supported
ObjectType=0x7
DataType=0x0005
AccessType=const
DefaultValue=2

[1018sub1]
ParameterName=Vendor-ID
DataType=0x0007
AccessType=ro
DefaultValue=0

[1018sub2]
ParameterName=Product code
DataType=0x0007
AccessType=ro
DefaultValue=010

[1400]
ParameterName=RPDO1 communication parameter
ObjectType=9
SubNumber=2

[1400sub0]
ParameterName=Highest sub-index supported
DataType=0x0005
AccessType=const
DefaultValue=5

[1400sub1]
ParameterName=COB-ID
DataType=0x0007
AccessType=rw
DefaultValue=$NODEID+0x200

[6071]
ParameterName=Target torque
DataType=0x0003
AccessType=rww
PDOMapping=1
DefaultValue=-1
LowLimit=-32768
HighLimit=32767

[6502]
ParameterName=Supported drive modes
DataType=0x0007
AccessType=ro
DefaultValue=0x180+$NODEID
)";

Eds parse(const std::string& text) { return parse_eds(text, "test.eds"); }

// The reader's error for `text`, which must be refused.
EdsError refused(const std::string& text) {
  try {
    parse(text);
  } catch (const EdsError& e) {
    return e;
  }
  ADD_FAILURE() << "accepted:\n" << text;
  return EdsError("", 0, "");
}

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

TEST(EdsNumber, DecimalHexOctalNegative) {
  EXPECT_EQ(parse_number("42"), 42);
  EXPECT_EQ(parse_number("0x2A"), 42);
  EXPECT_EQ(parse_number("0X2a"), 42);
  EXPECT_EQ(parse_number("052"), 42);  // octal
  EXPECT_EQ(parse_number("0"), 0);
  EXPECT_EQ(parse_number("-42"), -42);
  EXPECT_EQ(parse_number(" 7 "), 7);
  EXPECT_FALSE(parse_number(""));
  EXPECT_FALSE(parse_number("0x"));
  EXPECT_FALSE(parse_number("08"));  // not octal
  EXPECT_FALSE(parse_number("0x7G"));
  EXPECT_FALSE(parse_number("-0x10"));
  EXPECT_FALSE(parse_number("12abc"));
}

TEST(Eds, ParsesObjectsAndSubIndices) {
  const std::string text = kLists + kObjects;
  const Eds eds = parse(text);
  EXPECT_EQ(eds.file, "test.eds");
  ASSERT_EQ(eds.objects.size(), 5u);
  EXPECT_EQ(eds.mandatory, (std::vector<std::uint16_t>{0x1000, 0x1018}));
  EXPECT_EQ(eds.optional, (std::vector<std::uint16_t>{0x1400, 0x6071, 0x6502}));
  EXPECT_TRUE(eds.manufacturer.empty());

  const EdsEntry* type = eds.entry(0x1000, 0);
  ASSERT_NE(type, nullptr);
  EXPECT_EQ(type->name, "Device type");
  EXPECT_EQ(type->type(), DataType::kUnsigned32);
  EXPECT_EQ(type->access, Access::kRo);
  EXPECT_FALSE(type->pdo_mappable);
  EXPECT_EQ(type->line, line_of(text, "[1000]"));
  EXPECT_EQ(default_value(*type, 1), 0x00020192u);

  const EdsObject* id = eds.object(0x1018);
  ASSERT_NE(id, nullptr);
  EXPECT_EQ(id->object_type, ObjectType::kRecord);
  EXPECT_EQ(id->sub_number, 3);
  ASSERT_EQ(id->entries.size(), 3u);
  EXPECT_EQ(id->entries[0].access, Access::kConst);
  EXPECT_EQ(id->entries[0].type(), DataType::kUnsigned8);
  EXPECT_EQ(id->entries[2].name, "Product code");
  EXPECT_EQ(default_value(id->entries[2], 1), 8u);  // "010" is octal
  EXPECT_EQ(eds.entry(0x1018, 3), nullptr);
  EXPECT_EQ(eds.entry(0x1019, 0), nullptr);

  const EdsEntry* torque = eds.entry(0x6071, 0);
  ASSERT_NE(torque, nullptr);
  EXPECT_EQ(torque->type(), DataType::kInteger16);
  EXPECT_EQ(torque->access, Access::kRw);  // rww: written by the master, read as rw
  EXPECT_EQ(torque->access_text, "rww");
  EXPECT_TRUE(torque->pdo_mappable);
  EXPECT_EQ(default_value(*torque, 1), 0xFFFFu);  // -1 as INTEGER16
  EXPECT_EQ(torque->low_limit, "-32768");
}

// A DEFSTRUCT (ObjectType 6: a record type's definition, CiA 301 7.4.3, e.g. 0040h-025Fh) has
// sub-index sections as a RECORD does; a DEFTYPE (5) is one entry, as a VAR is.
TEST(Eds, DefStructHasSubIndicesDefTypeHasNone) {
  const std::string defs = R"(
[0007]
ParameterName=UNSIGNED32
ObjectType=0x5
DataType=0x0007
AccessType=ro
DefaultValue=32

[0040]
ParameterName=A record type
ObjectType=0x6
SubNumber=2

[0040sub0]
ParameterName=Highest sub-index supported
DataType=0x0005
AccessType=ro
DefaultValue=1

[0040sub1]
ParameterName=First member's type
DataType=0x0006
AccessType=ro
DefaultValue=0x0007

[ManufacturerObjects]
SupportedObjects=2
1=0x0007
2=0x0040
)";
  const std::string text = kLists + kObjects + defs;
  const Eds eds = parse(text);
  const EdsObject* s = eds.object(0x0040);
  ASSERT_NE(s, nullptr);
  EXPECT_EQ(s->object_type, ObjectType::kDefStruct);
  EXPECT_EQ(s->sub_number, 2);
  ASSERT_EQ(s->entries.size(), 2u);
  EXPECT_EQ(s->entries[1].subindex, 1);
  EXPECT_EQ(s->entries[1].line, line_of(text, "[0040sub1]"));
  EXPECT_EQ(default_value(s->entries[1], 1), 7u);
  const EdsObject* t = eds.object(0x0007);
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->object_type, ObjectType::kDefType);
  ASSERT_EQ(t->entries.size(), 1u);
  EXPECT_EQ(t->entries[0].subindex, 0);
  EXPECT_EQ(eds.manufacturer, (std::vector<std::uint16_t>{0x0007, 0x0040}));
  // SubNumber is required of a DEFSTRUCT as of a RECORD.
  const std::string no_count = replace(text, "ObjectType=0x6\nSubNumber=2\n", "ObjectType=0x6\n");
  EXPECT_EQ(refused(no_count).line(), line_of(no_count, "[0040]\n"));
}

TEST(Eds, NodeIdInDefaultValue) {
  const Eds eds = parse(kLists + kObjects);
  EXPECT_EQ(default_value(*eds.entry(0x1400, 1), 5), 0x205u);
  EXPECT_EQ(default_value(*eds.entry(0x1400, 1), 127), 0x27Fu);
  EXPECT_EQ(default_value(*eds.entry(0x6502, 0), 3), 0x183u);  // number + $NODEID
}

TEST(Eds, CaseAndWhitespaceAndCrLf) {
  std::string text = kLists + kObjects;
  text = replace(text, "[1018sub2]", "[1018SUB2]");
  text = replace(text, "ParameterName=Vendor-ID", "  parametername = Vendor-ID  ");
  std::string crlf;
  for (char c : text) {
    if (c == '\n') crlf += '\r';
    crlf += c;
  }
  const Eds eds = parse(crlf);
  ASSERT_NE(eds.entry(0x1018, 2), nullptr);
  EXPECT_EQ(eds.entry(0x1018, 1)->name, "Vendor-ID");
}

// ---- one test per malformation, each with its line ----------------------------------

TEST(EdsMalformed, UnknownSectionSyntax) {
  const std::string text = replace(kLists + kObjects, "[1018sub2]", "[1018s2]");
  const EdsError e = refused(text);
  EXPECT_EQ(e.line(), line_of(text, "[1018s2]"));
  EXPECT_NE(std::string(e.what()).find("test.eds:" + std::to_string(e.line()) +
                                       ": unknown section syntax [1018s2]"),
            std::string::npos)
      << e.what();
  const std::string digits = replace(kLists + kObjects, "[6502]", "[65020]");
  EXPECT_EQ(refused(digits).line(), line_of(digits, "[65020]"));
  const std::string open = replace(kLists + kObjects, "[6502]", "[6502");
  EXPECT_EQ(refused(open).line(), line_of(open, "[6502\n"));
}

TEST(EdsMalformed, MissingMandatoryKey) {
  const std::string text = replace(kLists + kObjects, "DataType=0x0003\n", "");
  const EdsError e = refused(text);
  EXPECT_EQ(e.line(), line_of(text, "[6071]"));
  EXPECT_NE(std::string(e.what()).find("[6071] lacks DataType"), std::string::npos) << e.what();

  const std::string no_name = replace(kLists + kObjects, "ParameterName=Vendor-ID\n", "");
  EXPECT_EQ(refused(no_name).line(), line_of(no_name, "[1018sub1]"));
  const std::string no_access =
      replace(kLists + kObjects, "AccessType=ro\nDefaultValue=0x0002", "DefaultValue=0x0002");
  EXPECT_EQ(refused(no_access).line(), line_of(no_access, "[1000]"));
  const std::string no_count = replace(kLists + kObjects, "SubNumber=3\n", "");
  EXPECT_NE(std::string(refused(no_count).what()).find("[1018] lacks SubNumber"),
            std::string::npos);
}

TEST(EdsMalformed, BadNumber) {
  const std::string text = replace(kLists + kObjects, "DataType=0x0003", "DataType=0x00G3");
  const EdsError e = refused(text);
  EXPECT_EQ(e.line(), line_of(text, "DataType=0x00G3"));
  EXPECT_NE(std::string(e.what()).find("bad number for DataType: '0x00G3'"), std::string::npos)
      << e.what();

  const std::string bad_default =
      replace(kLists + kObjects, "DefaultValue=0x00020192", "DefaultValue=2O");
  EXPECT_EQ(refused(bad_default).line(), line_of(bad_default, "DefaultValue=2O"));
  const std::string bad_node = replace(kLists + kObjects, "$NODEID+0x200", "$NODE+0x200");
  EXPECT_EQ(refused(bad_node).line(), line_of(bad_node, "$NODE+0x200"));
  // 300 does not fit UNSIGNED8 (1018h sub0).
  const std::string too_big = replace(kLists + kObjects, "DefaultValue=2\n", "DefaultValue=300\n");
  const EdsError big = refused(too_big);
  EXPECT_EQ(big.line(), line_of(too_big, "DefaultValue=300"));
  EXPECT_NE(std::string(big.what()).find("does not fit UNSIGNED8"), std::string::npos);
  const std::string mapping = replace(kLists + kObjects, "PDOMapping=1", "PDOMapping=2");
  EXPECT_EQ(refused(mapping).line(), line_of(mapping, "PDOMapping=2"));
  // Huge terms are refused, not summed into an overflow.
  const std::string huge =
      replace(kLists + kObjects, "$NODEID+0x200", "0x7FFFFFFFFFFFFFFF+0x7FFFFFFFFFFFFFFF");
  EXPECT_EQ(refused(huge).line(), line_of(huge, "0x7FFFFFFFFFFFFFFF+"));
  const std::string limit = replace(kLists + kObjects, "LowLimit=-32768", "LowLimit=$NODEID");
  EXPECT_EQ(refused(limit).line(), line_of(limit, "LowLimit=$NODEID"));
}

TEST(EdsMalformed, DuplicateSection) {
  const std::string extra = "\n[6502]\nParameterName=again\nDataType=7\nAccessType=ro\n";
  const std::string text = kLists + kObjects + extra;
  const EdsError e = refused(text);
  EXPECT_EQ(e.line(), line_of(text, extra.substr(1)));
  EXPECT_NE(std::string(e.what()).find("duplicate section [6502] (first at line " +
                                       std::to_string(line_of(text, "[6502]")) + ")"),
            std::string::npos)
      << e.what();
}

TEST(EdsMalformed, DuplicateKey) {
  const std::string text =
      replace(kLists + kObjects, "AccessType=rww\n", "AccessType=rww\naccesstype=ro\n");
  const EdsError e = refused(text);
  EXPECT_EQ(e.line(), line_of(text, "accesstype=ro"));
  EXPECT_NE(std::string(e.what()).find("duplicate key accesstype in [6071]"), std::string::npos)
      << e.what();
}

TEST(EdsMalformed, SubNumberMismatch) {
  const std::string text = replace(kLists + kObjects, "SubNumber=3", "SubNumber=4");
  const EdsError e = refused(text);
  EXPECT_EQ(e.line(), line_of(text, "SubNumber=4"));
  EXPECT_NE(std::string(e.what()).find("SubNumber=4 but 3 sub-index sections of 1018h"),
            std::string::npos)
      << e.what();
}

TEST(EdsMalformed, SubIndexWithoutObject) {
  const std::string extra = "\n[1019sub0]\nParameterName=x\nDataType=5\nAccessType=ro\n";
  const std::string text = kLists + kObjects + extra;
  const EdsError e = refused(text);
  EXPECT_EQ(e.line(), line_of(text, "[1019sub0]"));
  EXPECT_NE(std::string(e.what()).find("without its object section [1019]"), std::string::npos);
  // A VAR has no sub-index sections.
  const std::string var =
      kLists + kObjects + "\n[6502sub1]\nParameterName=x\nDataType=5\nAccessType=ro\n";
  EXPECT_EQ(refused(var).line(), line_of(var, "[6502sub1]"));
}

TEST(EdsMalformed, BadAccessTypeAndObjectType) {
  const std::string text = replace(kLists + kObjects, "AccessType=rww", "AccessType=readwrite");
  const EdsError e = refused(text);
  EXPECT_EQ(e.line(), line_of(text, "AccessType=readwrite"));
  const std::string type = replace(kLists + kObjects, "ObjectType=0x9", "ObjectType=0x4");
  EXPECT_EQ(refused(type).line(), line_of(type, "ObjectType=0x4"));
}

TEST(EdsMalformed, NotIniSyntax) {
  const std::string text = replace(kLists + kObjects, "PDOMapping=1\n", "PDOMapping 1\n");
  EXPECT_EQ(refused(text).line(), line_of(text, "PDOMapping 1"));
  const std::string before = "FileName=x.eds\n" + kLists + kObjects;
  EXPECT_EQ(refused(before).line(), 1);
  const std::string empty = replace(kLists + kObjects, "[6502]", "[ ]");
  EXPECT_EQ(refused(empty).line(), line_of(empty, "[ ]"));
}

TEST(EdsMalformed, ObjectListsAndSections) {
  // Listed without a section.
  const std::string listed = replace(kLists + kObjects, "3=0x6502", "3=0x6060");
  const EdsError a = refused(listed);
  EXPECT_EQ(a.line(), line_of(listed, "3=0x6060"));
  EXPECT_NE(std::string(a.what()).find("6060h is listed but has no [6060] section"),
            std::string::npos);
  // A section in no list (6502h is then unlisted).
  const std::string unlisted = replace(
      replace(kLists + kObjects, "SupportedObjects=3", "SupportedObjects=2"), "3=0x6502\n", "");
  EXPECT_EQ(refused(unlisted).line(), line_of(unlisted, "[6502]"));
  // The count disagrees with the entries.
  const std::string count = replace(kLists + kObjects, "SupportedObjects=3", "SupportedObjects=4");
  EXPECT_EQ(refused(count).line(), line_of(count, "SupportedObjects=4"));
}

TEST(EdsMalformed, CompactSubObjNotSupported) {
  const std::string text = replace(kLists + kObjects, "SubNumber=2", "CompactSubObj=2");
  EXPECT_EQ(refused(text).line(), line_of(text, "CompactSubObj=2"));
}

TEST(EdsFile, UnreadableAndBinary) {
  try {
    read_eds_file("/nonexistent/drive.eds");
    ADD_FAILURE();
  } catch (const EdsError& e) {
    EXPECT_EQ(e.file(), "/nonexistent/drive.eds");
    EXPECT_EQ(e.line(), 0);
  }
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("dualv_eds_test_" + std::to_string(::getpid()) + ".eds"))
                               .string();
  {
    std::ofstream f(path, std::ios::binary);
    f << kLists << kObjects;
  }
  EXPECT_EQ(read_eds_file(path).objects.size(), 5u);
  {
    std::ofstream f(path, std::ios::binary);
    f << std::string("\0\1\2", 3);
  }
  EXPECT_THROW(read_eds_file(path), EdsError);
  std::remove(path.c_str());
}

}  // namespace
}  // namespace dualv::fw::eds
