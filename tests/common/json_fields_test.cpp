// The shared JSON field checks: each error's field path and message apart,
// and its text as every parser printed it ("field: message").
#include "common/json_fields.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>

namespace tally::json_fields {
namespace {

using nlohmann::json;

// The error of a failed result, checked field and message apart and joined.
template <class T>
void expectError(const Result<T>& r, const std::string& field, const std::string& message) {
  ASSERT_FALSE(r.ok()) << "accepted; expected " << field << ": " << message;
  EXPECT_EQ(r.failure().field(), field);
  EXPECT_EQ(r.failure().message(), message);
  EXPECT_EQ(r.error(), field.empty() ? message : field + ": " + message);
}

TEST(JsonFields, AnErrorWithoutAFieldPrintsItsMessageAlone) {
  Result<int> r = makeError("the file is gone");
  EXPECT_EQ(r.failure().field(), "");
  EXPECT_EQ(r.error(), "the file is gone");
}

TEST(JsonFields, PathsJoinMembersAndIndices) {
  EXPECT_EQ(member("", "frames"), "frames");
  EXPECT_EQ(member("passes.shading", "width"), "passes.shading.width");
  EXPECT_EQ(index("resolutions", 2), "resolutions[2]");
  EXPECT_EQ(index(index("region", 1), 0), "region[1][0]");
}

TEST(JsonFields, NestedErrorsMoveUnderTheirParent) {
  Error option("barycentrics", "\"half\" is not one of unorm16, float32");
  Error moved = under("renderers[1].options", option);
  EXPECT_EQ(moved.field(), "renderers[1].options.barycentrics");
  EXPECT_EQ(moved.text(), "renderers[1].options.barycentrics: \"half\" is not one of unorm16, float32");
  // A list's error starts with its index.
  EXPECT_EQ(under("cameras", Error("[0].target", "must differ from eye")).text(),
            "cameras[0].target: must differ from eye");
  // An error without a field is the parent's.
  Error bare = under("gltf", makeError("cannot open scene.gltf"));
  EXPECT_EQ(bare.field(), "gltf");
  EXPECT_EQ(bare.message(), "cannot open scene.gltf");
}

TEST(JsonFields, UnknownKeysNameTheKeyAndListTheAllowedOnes) {
  json spec = {{"frames", 2}, {"colour", "red"}};
  auto e = unknownKey(spec, "", {"frames", "lights"});
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->field(), "colour");
  EXPECT_EQ(e->message(), "unknown field (expected frames, lights)");
  // Under a path, with the parser's own heading.
  auto nested = unknownKey(json{{"layout", "floor"}, {"rings", 3}}, "heatmap", {"cells", "layout"},
                           "unknown field for the floor layout");
  ASSERT_TRUE(nested.has_value());
  EXPECT_EQ(nested->text(), "heatmap.rings: unknown field for the floor layout (expected cells, layout)");
  EXPECT_FALSE(unknownKey(json{{"frames", 1}}, "", {"frames"}).has_value());
}

TEST(JsonFields, IntegersAreBoundedAndCheckedForInt64Overflow) {
  EXPECT_EQ(*integer(json(5), "frames", 1, 10), 5);
  expectError(integer(json(0), "frames", 1, 10), "frames", "must be an integer between 1 and 10, got 0");
  expectError(integer(json(11), "frames", 1, 10), "frames", "must be an integer between 1 and 10, got 11");
  expectError(integer(json(2.5), "frames", 1, 10), "frames", "must be an integer between 1 and 10, got 2.5");
  expectError(integer(json("3"), "frames", 1, 10), "frames",
              "must be an integer between 1 and 10, got \"3\"");
  // 2^63 is a valid JSON unsigned that int64 cannot hold: refused, not wrapped to INT64_MIN.
  json beyond = json(uint64_t{1} << 63);
  expectError(
      integer(beyond, "n", INT64_MIN, INT64_MAX), "n",
      "must be an integer between -9223372036854775808 and 9223372036854775807, got 9223372036854775808");
  EXPECT_EQ(*integer(json(INT64_MAX), "n", INT64_MIN, INT64_MAX), INT64_MAX);
  EXPECT_EQ(*integer(json(INT64_MIN), "n", INT64_MIN, INT64_MAX), INT64_MIN);

  EXPECT_EQ(*anyInteger(json(uint64_t(INT64_MAX)), "id"), INT64_MAX);
  expectError(anyInteger(beyond, "id"), "id", "too large");
  expectError(anyInteger(json("7"), "id"), "id", "must be an integer, got \"7\"");

  // The sweeps' wording of the same range.
  expectError(count(json(0), "layers[1]", 1, 64, RangeWords::kFromTo), "layers[1]",
              "must be an integer from 1 to 64, got 0");
  EXPECT_EQ(*count(json(400), "lights", 0, 400), 400u);
  expectError(count(json(-1), "lights", 0, 400), "lights", "must be an integer between 0 and 400, got -1");
}

TEST(JsonFields, NumbersAreFiniteAndBounded) {
  EXPECT_EQ(*number(json(0.5), "coverage", 0.0, 1.0, true), 0.5);
  expectError(number(json(0), "heatmap.distance", 0.0, 100.0, true), "heatmap.distance",
              "must be a number above 0 up to 100, got 0");
  expectError(number(json(-90), "heatmap.pitch_deg", -89.0, 89.0), "heatmap.pitch_deg",
              "must be a number from -89 to 89, got -90");
  expectError(finite(json("x"), "passes[0].bytes"), "passes[0].bytes", "must be a number, got \"x\"");
  expectError(finite(json(std::numeric_limits<double>::infinity()), "t"), "t", "must be finite");
}

TEST(JsonFields, BooleansStringsAndChoices) {
  EXPECT_TRUE(*boolean(json(true), "ceilings"));
  expectError(boolean(json(1), "ceilings"), "ceilings", "must be true or false, got 1");
  expectError(text(json(3), "counting[1]"), "counting[1]", "must be a string, got 3");
  expectError(boundedText(json(""), "application.name", 8), "application.name",
              "must be a non-empty string of at most 8 characters without NUL");
  EXPECT_EQ(*boundedText(json(""), "env.X", 8, true), "");
  expectError(boundedText(json(std::string("a\0b", 3)), "env.X", 8, true), "env.X",
              "must be at most 8 characters without NUL");
  EXPECT_EQ(*oneOf(json("xvfb"), "display", {"none", "xvfb"}), "xvfb");
  expectError(oneOf(json("x11"), "display", {"none", "xvfb"}), "display",
              "must be \"none\" or \"xvfb\", got \"x11\"");
  expectError(oneOf(json(2), "counting", {"accumulate", "exact"}, "(the layer's modes)"), "counting",
              "must be \"accumulate\" or \"exact\" (the layer's modes), got 2");
  expectError(oneOf(json("z"), "k", {"a", "b", "c"}), "k", "must be \"a\", \"b\" or \"c\", got \"z\"");
}

TEST(JsonFields, ResolutionsNameTheAxisAtFault) {
  auto ok = resolution(json{1280, 720}, "resolutions[0]");
  ASSERT_TRUE(ok.ok()) << ok.error();
  EXPECT_EQ(ok->width, 1280u);
  EXPECT_EQ(ok->height, 720u);
  expectError(resolution(json("64x36"), "resolutions[2]"), "resolutions[2]",
              "must be [width, height], got \"64x36\"");
  expectError(resolution(json{64, 0}, "resolutions[2]"), "resolutions[2][1]",
              "must be an integer between 1 and 16384, got 0");
  expectError(resolution(json{16385, 8}, "resolution"), "resolution[0]",
              "must be an integer between 1 and 16384, got 16385");
  expectError(resolution(json{16384, 16384}, "resolutions[0]"), "resolutions[0]",
              "16384x16384 is more than the 33177600-pixel limit (8K)");
  expectError(resolution(json{96, 0}, "resolution", {1, 1}, RangeWords::kFromTo), "resolution[1]",
              "must be an integer from 1 to 16384, got 0");
  // A tiled renderer's least size says why.
  expectError(resolution(json{3, 64}, "resolution", Resolution{4, 4}), "resolution[0]",
              "must be an integer from 4 (one tile) to 16384, got 3");
}

TEST(JsonFields, ListsAndDuplicates) {
  auto e = tooMany(json::array({1, 2, 3}), "scenes", 2);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->text(), "scenes: at most 2 entries, got 3");
  EXPECT_FALSE(tooMany(json::array({1, 2}), "scenes", 2).has_value());
  EXPECT_EQ(duplicate("scenes[3]", "scenes[0]").text(),
            "scenes[3]: a duplicate of scenes[0] (each entry must differ)");
}

struct Refused : std::runtime_error {
  using std::runtime_error::runtime_error;
};

TEST(JsonFields, MembersOfAWholeDocumentThrowWithTheirPath) {
  const Members m{[](const Error& error) { throw Refused(error.text()); }};
  json sample = {{"passes", {{{"name", "shading"}, {"bytes", 12}}}}, {"note", nullptr}};
  const json& pass = m.array(sample, "passes", "samples[0]")[0];
  EXPECT_EQ(m.text(pass, "name", "samples[0].passes[0]"), "shading");
  EXPECT_EQ(m.integer(pass, "bytes", "samples[0].passes[0]"), 12);
  EXPECT_FALSE(m.optText(sample, "note", "samples[0]").has_value());  // null reads as absent
  EXPECT_TRUE(m.object(sample, "extras", "samples[0]").empty());
  auto message = [](auto read) -> std::string {
    try {
      read();
    } catch (const Refused& e) {
      return e.what();
    }
    return "(nothing thrown)";
  };
  EXPECT_EQ(message([&] { m.number(pass, "time", "samples[0].passes[0]"); }),
            "samples[0].passes[0].time: missing");
  EXPECT_EQ(message([&] { m.integer(json{{"id", uint64_t{1} << 63}}, "id", "run"); }), "run.id: too large");
  EXPECT_EQ(message([&] { m.array(sample, "note", "x"); }), "(nothing thrown)");
  EXPECT_EQ(message([&] { m.object(pass, "name", "samples[0].passes[0]"); }),
            "samples[0].passes[0].name: must be an object");
}

// findAll reads each key as find() does, whatever members sit between,
// before or after the keys; null reads as absent; a non-object has none.
TEST(JsonFields, FindAllReadsEachKeyAsFindDoes) {
  constexpr std::array<std::string_view, 5> keys = {"b", "bb", "count", "count_spread", "z"};
  static_assert(inMemberOrder(keys));
  static_assert(!inMemberOrder(std::array<std::string_view, 2>{"count_spread", "count"}));
  static_assert(!inMemberOrder(std::array<std::string_view, 2>{"a", "a"}));
  const std::vector<json> objects = {
      json::object(),
      {{"a", 1}, {"b", 2}, {"bb", nullptr}, {"c", 3}, {"count", 4}, {"count_spread", {{"n", 1}}}, {"z", "last"}},
      {{"bb", 1}, {"count_s", 2}, {"zz", 3}},
      {{"aa", 1}, {"ab", 2}, {"z", nullptr}, {"zz", 4}},
      {{"count", 1}},
      json::array({1, 2}),
      json(3)};
  for (const json& object : objects) {
    SCOPED_TRACE(object.dump());
    auto found = findAll(object, keys);
    for (size_t k = 0; k < keys.size(); ++k) {
      EXPECT_EQ(found[k], object.is_object() ? find(object, keys[k]) : nullptr) << keys[k];
    }
  }
  auto both = findAll(objects[1], keys);
  ASSERT_NE(both[3], nullptr);
  EXPECT_EQ((*both[3])["n"], 1);
  EXPECT_EQ(both[1], nullptr);  // null
}

}  // namespace
}  // namespace tally::json_fields
