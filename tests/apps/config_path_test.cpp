// apps/config_path.hpp (issue 14, defect 7): the help texts name the very files the
// resolvers return, so `--help` tells where a default comes from (it said "beside the
// config" while the program came from the build's config folder whatever --config said).
#include "apps/config_path.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

namespace dualv::apps {
namespace {

bool contains(const std::string& s, const std::string& f) { return s.find(f) != std::string::npos; }

TEST(ConfigPath, HelpNamesTheFilesTheDefaultsResolveTo) {
  EXPECT_TRUE(contains(program_help(), resolve_program(""))) << program_help();
  EXPECT_TRUE(contains(keys_help(), resolve_keys_dir(""))) << keys_help();
  ::unsetenv("DUALV_CONFIG");
  EXPECT_TRUE(contains(config_help(), resolve_config(""))) << config_help();
  for (const std::string& h : {program_help(), keys_help(), config_help()})
    EXPECT_FALSE(contains(h, "beside")) << h;
}

// The defaults do not follow --config: a config elsewhere still gets the build's program.
TEST(ConfigPath, DefaultsComeFromTheBuildsConfigFolderNotFromTheConfigFile) {
  ::setenv("DUALV_CONFIG", "/somewhere/else/robot.yaml", 1);
  EXPECT_EQ(resolve_config(""), "/somewhere/else/robot.yaml");
  EXPECT_EQ(resolve_program(""), default_config_dir() + "/paper.yaml");
  EXPECT_EQ(resolve_keys_dir(""), default_config_dir() + "/keys");
  EXPECT_EQ(resolve_config("given.yaml"), "given.yaml");
  EXPECT_EQ(resolve_program("p.yaml"), "p.yaml");
  ::unsetenv("DUALV_CONFIG");
  EXPECT_EQ(resolve_config(""), default_config_dir() + "/dualv.yaml");
  EXPECT_EQ(resolve_named_program("no-such-program"),
            default_config_dir() + "/no-such-program.yaml");
}

}  // namespace
}  // namespace dualv::apps
