// The loader: what a good plugin registers, how each bad file is refused, object lifetimes and
// the search path.
#include <dlfcn.h>
#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <fstream>
#include <string>
#include <vector>

#include "projtour/host/params_reader.hpp"
#include "projtour/host/plugin_loader.hpp"
#include "projtour_test/fixture_support.hpp"
#include "projtour_test/scoped_state.hpp"

namespace fs = std::filesystem;
using projtour::ParamType;
using projtour::host::Family;
using projtour::host::KindInfo;
using projtour::host::PluginError;
using projtour::host::PluginLoadOptions;
using projtour::host::PluginRegistry;
using projtour::testing::fixture;
using projtour::testing::TempDir;
using projtour::testing::TestRun;
namespace host = projtour::host;

namespace {

// The message load_library throws for `file`, or "" when it loads.
std::string load_error(host::PluginRegistry& registry, const fs::path& file) {
  try {
    registry.load_library(file);
  } catch (const host::PluginError& e) {
    return e.what();
  }
  return "";
}

bool is_loaded(const fs::path& file) {
  void* handle = dlopen(fs::canonical(file).c_str(), RTLD_NOW | RTLD_NOLOAD);
  if (handle == nullptr) return false;
  dlclose(handle);
  return true;
}

projtour::Params wait_params(const host::PluginRegistry& registry, const std::string& yaml) {
  projtour::host::Diagnostics diag;
  auto params =
      projtour::testing::params_from_yaml(registry.require("fixture_wait").params, yaml, diag);
  EXPECT_FALSE(diag.has_errors()) << diag.format();
  return params;
}

using projtour::test::ScopedCurrentPath;
using projtour::test::ScopedEnv;

TEST(PluginLoader, GoodPluginRegistersEveryKind) {
  host::PluginRegistry registry;
  registry.load_library(fixture("pt_fixture_good"));

  const auto kinds = registry.kinds();
  ASSERT_EQ(kinds.size(), 3u);
  EXPECT_EQ(kinds[0]->name, "fixture_locator");
  EXPECT_EQ(kinds[1]->name, "fixture_projector");
  EXPECT_EQ(kinds[2]->name, "fixture_wait");

  const host::KindInfo& wait = registry.require("fixture_wait");
  EXPECT_EQ(wait.family, host::Family::behaviour);
  EXPECT_EQ(wait.interface, "");
  EXPECT_EQ(wait.description, "waits, then succeeds");
  EXPECT_EQ(wait.plugin_name, "fixture_good");
  EXPECT_EQ(wait.plugin_version, "1.2.3");
  EXPECT_EQ(wait.library, fs::canonical(fixture("pt_fixture_good")));
  ASSERT_EQ(wait.params.size(), 5u);
  EXPECT_EQ(wait.params[0].name, "duration_s");
  EXPECT_EQ(wait.params[0].type, ParamType::number);
  EXPECT_EQ(wait.params[0].default_value, "2.5");
  EXPECT_EQ(wait.params[0].description, "mission time to wait");
  EXPECT_EQ(wait.params[1].type, ParamType::integer);
  EXPECT_EQ(wait.params[2].type, ParamType::boolean);
  EXPECT_EQ(wait.params[3].type, ParamType::string);
  EXPECT_FALSE(wait.params[3].required());
  EXPECT_TRUE(wait.params[4].required());
  EXPECT_EQ(wait.outcomes, (std::vector<std::string>{"succeeded", "timed_out"}));
  EXPECT_TRUE(wait.declares_outcome("timed_out"));
  EXPECT_FALSE(wait.declares_outcome("failed"));

  EXPECT_EQ(registry.require("fixture_projector").family, host::Family::driver);
  EXPECT_EQ(registry.require("fixture_projector").interface, "projector");
  EXPECT_EQ(registry.require("fixture_locator").family, host::Family::service);
  EXPECT_EQ(registry.require("fixture_locator").interface, "localization");
}

TEST(PluginLoader, LoadingTheSameFileTwiceIsHarmless) {
  host::PluginRegistry registry;
  registry.load_library(fixture("pt_fixture_good"));
  EXPECT_NO_THROW(registry.load_library(fixture("pt_fixture_good")));
  EXPECT_EQ(registry.kinds().size(), 3u);
}

TEST(PluginLoader, MissingFileIsNamedWithErrno) {
  host::PluginRegistry registry;
  const std::string error = load_error(registry, "/nonexistent/libnothing.so");
  EXPECT_EQ(error, "/nonexistent/libnothing.so: cannot open: No such file or directory");
}

// exists() reads a loop as a missing file; the loader must say what really stopped it.
TEST(PluginLoader, SymlinkLoopIsReportedAsEloopNotAsMissing) {
  TempDir dir;
  const fs::path file = dir / "libloop.so";
  fs::create_symlink(dir / "libloop_back.so", file);
  fs::create_symlink(file, dir / "libloop_back.so");
  host::PluginRegistry registry;
  EXPECT_EQ(load_error(registry, file),
            file.string() + ": cannot open: Too many levels of symbolic links");
  EXPECT_EQ(registry.load_directories({dir.path()}),
            (std::vector<std::string>{
                (dir / "libloop.so").string() + ": cannot open: Too many levels of symbolic links",
                (dir / "libloop_back.so").string() +
                    ": cannot open: Too many levels of symbolic links"}));
}

TEST(PluginLoader, FileThatIsNotElfIsRefusedBeforeDlopen) {
  TempDir dir;
  const fs::path file = dir.path() / "libgarbage.so";
  std::ofstream(file) << std::string(512, 'x');
  host::PluginRegistry registry;
  EXPECT_EQ(load_error(registry, file),
            file.string() + ": not an ELF shared object (no ELF header)");
  EXPECT_FALSE(projtour::test::mapped_in_this_process(file));
}

TEST(PluginLoader, ElfThatIsNotASharedObjectIsRefused) {
  TempDir dir;
  const fs::path file = dir.path() / "libobject.so";
  // A relocatable object's header: ELF, 64-bit, little-endian, e_type 1.
  std::string header =
      "\x7f"
      "ELF\x02\x01\x01";
  header.resize(16, '\0');
  header += std::string("\x01\x00", 2);
  header.resize(64, '\0');
  std::ofstream(file, std::ios::binary) << header;
  host::PluginRegistry registry;
  EXPECT_EQ(load_error(registry, file),
            file.string() + ": not an ELF shared object (ELF type 1, a shared object is 3)");
}

// glibc maps a truncated library's segments past the end of the file and touches them: the
// host would die of SIGBUS inside dlopen.
TEST(PluginLoader, TruncatedSharedObjectIsRefusedBeforeDlopen) {
  TempDir dir;
  const fs::path file = dir.path() / "libtruncated.so";
  std::ifstream good(fixture("pt_fixture_good"), std::ios::binary);
  std::string head(4096, '\0');
  good.read(head.data(), static_cast<std::streamsize>(head.size()));
  std::ofstream(file, std::ios::binary) << head;
  host::PluginRegistry registry;
  const std::string error = load_error(registry, file);
  EXPECT_EQ(error.rfind(file.string() + ": truncated ELF shared object (segment ", 0), 0u) << error;
  EXPECT_NE(error.find(", the file has 4096)"), std::string::npos) << error;
  EXPECT_FALSE(projtour::test::mapped_in_this_process(file));
}

TEST(PluginLoader, UnloadableSharedObjectCarriesDlerror) {
  TempDir dir;
  const fs::path file = dir.path() / "libwrongclass.so";
  // A shared object's header of the other word size: only the dynamic linker judges that.
  std::string header =
      "\x7f"
      "ELF";
  header += sizeof(void*) == 8 ? '\x01' : '\x02';
  header += "\x01\x01";
  header.resize(16, '\0');
  header += std::string("\x03\x00", 2);
  header.resize(512, '\0');
  std::ofstream(file, std::ios::binary) << header;
  host::PluginRegistry registry;
  const std::string error = load_error(registry, file);
  EXPECT_EQ(error.rfind(file.string() + ": cannot load: ", 0), 0u) << error;
  // dlerror's own words follow: the reason the dynamic linker refused it.
  EXPECT_NE(error.find("wrong ELF class"), std::string::npos) << error;
}

TEST(PluginLoader, SharedObjectWithoutEntryPointIsNotAPlugin) {
  host::PluginRegistry registry;
  const fs::path file = fixture("pt_fixture_not_plugin");
  EXPECT_EQ(load_error(registry, file),
            file.string() + ": not a projtour plugin (no projtour_plugin_descriptor)");
  EXPECT_TRUE(registry.kinds().empty());
}

TEST(PluginLoader, AbiVersionIsCheckedBeforeAnythingElse) {
  // The fixture's other fields are null: reading them first would report a malformed plugin.
  host::PluginRegistry registry;
  const fs::path file = fixture("pt_fixture_abi999");
  EXPECT_EQ(load_error(registry, file), file.string() + ": ABI version 999, this projtour needs " +
                                            std::to_string(PROJTOUR_ABI_VERSION));
}

struct MalformedCase {
  int number;
  std::string reason;
};

class MalformedDescriptor : public ::testing::TestWithParam<MalformedCase> {};

TEST_P(MalformedDescriptor, IsRefusedWithTheReason) {
  const fs::path file = fixture("pt_fixture_malformed_" + std::to_string(GetParam().number));
  host::PluginRegistry registry;
  EXPECT_EQ(load_error(registry, file), file.string() + ": " + GetParam().reason);
  EXPECT_EQ(registry.find("fixture_malformed"), nullptr);
  EXPECT_TRUE(registry.kinds().empty());
}

INSTANTIATE_TEST_SUITE_P(
    PluginLoader, MalformedDescriptor,
    ::testing::Values(
        MalformedCase{1, "kind 0: null or empty name"},
        MalformedCase{2,
                      "kind \"fixture_malformed\": unknown family 7 (expected 1 behaviour, 2 "
                      "driver or 3 service)"},
        MalformedCase{3,
                      "kind \"fixture_malformed\": parameter \"tolerance_m\": unknown type "
                      "\"float\" (expected number, integer, boolean or string)"},
        MalformedCase{4,
                      "kind \"fixture_malformed\": driver interface \"hoverboard\" is not one of "
                      "base, laser, pan_tilt, depth_camera, projector, colour_camera"},
        MalformedCase{5, "kind \"fixture_malformed\": null create function"},
        MalformedCase{6,
                      "kind \"fixture_malformed\": parameter \"tolerance_m\": default \"north\" "
                      "is not a number"},
        MalformedCase{7,
                      "kind \"fixture_malformed\": key \"capture\": unknown access 9 (expected 1 "
                      "read, 2 read if present or 3 write)"}));

TEST(PluginLoader, DuplicateKindNamesBothFiles) {
  host::PluginRegistry registry;
  const fs::path a = fixture("pt_fixture_dup_a");
  const fs::path b = fixture("pt_fixture_dup_b");
  registry.load_library(a);
  EXPECT_EQ(load_error(registry, b), b.string() + ": kind \"fixture_dup\" is already provided by " +
                                         fs::canonical(a).string() + " (plugin \"fixture_dup_a\")");
  // The first provider keeps the kind.
  EXPECT_EQ(registry.require("fixture_dup").plugin_name, "fixture_dup_a");
}

TEST(PluginLoader, LoadDirectoriesCollectsEveryFailureInFileOrder) {
  host::PluginRegistry registry;
  const auto failures =
      registry.load_directories({PROJTOUR_FIXTURE_DIR, "/nonexistent/projtour/plugins"});
  const std::string dir = PROJTOUR_FIXTURE_DIR;
  std::vector<std::string> failed_files;
  for (const auto& f : failures) failed_files.push_back(f.substr(0, f.find(".so: ") + 3));
  const std::vector<std::string> expected = {
      dir + "/libpt_fixture_abi999.so",      dir + "/libpt_fixture_constructor.so",
      dir + "/libpt_fixture_dup_b.so",       dir + "/libpt_fixture_malformed_1.so",
      dir + "/libpt_fixture_malformed_2.so", dir + "/libpt_fixture_malformed_3.so",
      dir + "/libpt_fixture_malformed_4.so", dir + "/libpt_fixture_malformed_5.so",
      dir + "/libpt_fixture_malformed_6.so", dir + "/libpt_fixture_malformed_7.so",
      dir + "/libpt_fixture_not_plugin.so"};
  EXPECT_EQ(failed_files, expected);

  std::vector<std::string> names;
  for (const host::KindInfo* kind : registry.kinds()) names.push_back(kind->name);
  EXPECT_EQ(names, (std::vector<std::string>{"fixture_create_throws", "fixture_dup", "fixture_liar",
                                             "fixture_locator", "fixture_projector",
                                             "fixture_tick_throws", "fixture_wait"}));
  EXPECT_EQ(registry.require("fixture_dup").plugin_name, "fixture_dup_a");
}

TEST(PluginLoader, EarlierDirectoryShadowsSameFileName) {
  TempDir first;
  TempDir second;
  for (const auto* dir : {&first, &second}) {
    fs::copy_file(fixture("pt_fixture_good"), dir->path() / "libpt_fixture_good.so");
  }
  host::PluginRegistry registry;
  EXPECT_TRUE(registry.load_directories({first.path(), second.path()}).empty());
  EXPECT_EQ(registry.require("fixture_wait").library.parent_path(), fs::canonical(first.path()));
}

TEST(PluginLoader, RequireSuggestsTheClosestKind) {
  host::PluginRegistry registry;
  registry.load_library(fixture("pt_fixture_good"));
  try {
    registry.require("fixture_wiat");
    FAIL() << "no throw";
  } catch (const host::PluginError& e) {
    EXPECT_STREQ(e.what(), "unknown plugin kind \"fixture_wiat\" (did you mean \"fixture_wait\"?)");
  }
  EXPECT_THROW(registry.require("navigate"), host::PluginError);
  EXPECT_EQ(registry.find("navigate"), nullptr);
}

TEST(PluginLoader, BehaviourRunsOnMissionTime) {
  host::PluginRegistry registry;
  registry.load_library(fixture("pt_fixture_good"));
  const auto params = wait_params(registry, "{gain: 1.0, duration_s: 2.0}");
  TestRun run;
  auto behaviour = registry.create_behaviour("fixture_wait", params, run.run);
  ASSERT_NE(behaviour, nullptr);
  auto ctx = run.context(params);
  run.clock.set(10.0);
  behaviour->start(ctx);
  run.clock.advance(1.9);
  EXPECT_FALSE(behaviour->tick(ctx).has_value());
  run.clock.advance(0.2);
  const auto outcome = behaviour->tick(ctx);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->name, "succeeded");
  EXPECT_EQ(outcome->message, "hello");
}

// A copy of the fixture under a name of its own: no other test of this process can have loaded
// it before (a library is never unloaded), so "not mapped yet" is a fact to start from.
TEST(PluginLoader, LibraryStaysMappedWhileAnObjectLivesAndAfter) {
  TempDir dir;
  const fs::path file = dir.path() / "libpt_fixture_lifetime.so";
  fs::copy_file(fixture("pt_fixture_good"), file);
  ASSERT_FALSE(is_loaded(file));
  ASSERT_FALSE(projtour::test::mapped_in_this_process(file));
  TestRun run;
  std::shared_ptr<projtour::Behaviour> behaviour;
  projtour::Params params;
  {
    auto registry = std::make_unique<host::PluginRegistry>();
    registry->load_library(file);
    EXPECT_TRUE(projtour::test::mapped_in_this_process(file));
    params = wait_params(*registry, "{gain: 1.0, duration_s: 0.0, fail_on_timeout: true}");
    behaviour = registry->create_behaviour("fixture_wait", params, run.run);
  }
  // The registry is gone; the object's code and vtable must still be there, and run.
  EXPECT_TRUE(is_loaded(file));
  EXPECT_TRUE(projtour::test::mapped_in_this_process(file));
  auto ctx = run.context(params);
  behaviour->start(ctx);
  const auto outcome = behaviour->tick(ctx);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->name, "timed_out");
  behaviour.reset();
  // Never unmapped (RTLD_NODELETE): values a plugin left on a blackboard or in an exception
  // may still run its code at teardown, after the last object and the registry are gone.
  EXPECT_TRUE(is_loaded(file));
  EXPECT_TRUE(projtour::test::mapped_in_this_process(file));
}

TEST(PluginLoader, CreateThatThrowsNamesKindLibraryAndReason) {
  host::PluginRegistry registry;
  registry.load_library(fixture("pt_fixture_throwing"));
  TestRun run;
  try {
    registry.create_behaviour("fixture_create_throws", projtour::Params(), run.run);
    FAIL() << "no throw";
  } catch (const host::PluginError& e) {
    EXPECT_EQ(std::string(e.what()),
              fs::canonical(fixture("pt_fixture_throwing")).string() +
                  ": kind \"fixture_create_throws\": create failed: calibration file missing");
  }
}

TEST(PluginLoader, TickThatThrowsReachesTheCaller) {
  host::PluginRegistry registry;
  registry.load_library(fixture("pt_fixture_throwing"));
  const auto params =
      projtour::host::default_params(registry.require("fixture_tick_throws").params);
  TestRun run;
  auto behaviour = registry.create_behaviour("fixture_tick_throws", params, run.run);
  auto ctx = run.context(params);
  behaviour->start(ctx);
  EXPECT_THROW(
      {
        try {
          behaviour->tick(ctx);
        } catch (const std::runtime_error& e) {
          EXPECT_STREQ(e.what(), "fixture tick failure");
          throw;
        }
      },
      std::runtime_error);
}

TEST(PluginLoader, FamilyMismatchIsRefused) {
  host::PluginRegistry registry;
  registry.load_library(fixture("pt_fixture_good"));
  TestRun run;
  const std::string library = fs::canonical(fixture("pt_fixture_good")).string();
  try {
    registry.create_driver("fixture_wait", projtour::Params(), run.run);
    FAIL() << "no throw";
  } catch (const host::PluginError& e) {
    EXPECT_EQ(std::string(e.what()),
              library + ": kind \"fixture_wait\": is a behaviour, not a driver");
  }
  EXPECT_THROW(registry.create_behaviour("fixture_projector", projtour::Params(), run.run),
               host::PluginError);
  EXPECT_THROW(registry.create_service("fixture_projector", projtour::Params(), run.run),
               host::PluginError);
}

TEST(PluginLoader, DriverMustImplementItsDeclaredInterface) {
  host::PluginRegistry registry;
  registry.load_library(fixture("pt_fixture_liar"));
  TestRun run;
  const auto params = projtour::host::default_params(registry.require("fixture_liar").params);
  try {
    registry.create_driver("fixture_liar", params, run.run);
    FAIL() << "no throw";
  } catch (const host::PluginError& e) {
    EXPECT_NE(std::string(e.what()).find("kind \"fixture_liar\": declares interface \"base\" but "
                                         "its object does not implement it"),
              std::string::npos)
        << e.what();
  }
}

TEST(PluginLoader, DriverDowncastsToItsInterface) {
  host::PluginRegistry registry;
  registry.load_library(fixture("pt_fixture_good"));
  TestRun run;
  const auto params = projtour::host::default_params(registry.require("fixture_projector").params);
  auto driver = registry.create_driver("fixture_projector", params, run.run);
  auto projector = std::dynamic_pointer_cast<projtour::ProjectorDriver>(driver);
  ASSERT_NE(projector, nullptr);
  EXPECT_EQ(std::dynamic_pointer_cast<projtour::BaseDriver>(driver), nullptr);
  EXPECT_TRUE(projector->is_blank());
}

TEST(PluginLoader, ServiceIsCreatedAndUpdated) {
  host::PluginRegistry registry;
  registry.load_library(fixture("pt_fixture_good"));
  TestRun run;
  const auto params = projtour::host::default_params(registry.require("fixture_locator").params);
  auto service = registry.create_service("fixture_locator", params, run.run);
  ASSERT_NE(service, nullptr);
  auto ctx = run.context(params);
  service->start(ctx);
  EXPECT_NO_THROW(service->update(ctx));
}

TEST(PluginLoader, KindValidatorRunsOnValues) {
  host::PluginRegistry registry;
  registry.load_library(fixture("pt_fixture_good"));
  EXPECT_EQ(registry.validate_params("fixture_wait", wait_params(registry, "{gain: 1}")), "");
  EXPECT_EQ(
      registry.validate_params("fixture_wait", wait_params(registry, "{gain: 1, repeats: 0}")),
      "repeats must be at least 1");
  // No validator: always fine.
  EXPECT_EQ(registry.validate_params("fixture_projector", projtour::Params()), "");
}

// The last entry is the directory beside the host library: in the build tree that is the build
// tree's plugin directory because the tree has an installation's layout, not because a path
// was compiled in (plugins_install_template checks an installed host never names the tree).
TEST(PluginSearchPath, CliThenEnvironmentThenBesideTheHostLibrary) {
  ScopedEnv env("PROJTOUR_PLUGIN_PATH", "/env/a::/env/b:");
  const auto dirs = host::PluginRegistry::search_path({"/cli/x", "/cli/y/"});
  EXPECT_EQ(dirs, (std::vector<fs::path>{"/cli/x", "/cli/y/", "/env/a", "/env/b",
                                         fs::path(PROJTOUR_PLUGIN_BUILD_DIR)}));
  for (const auto& dir : dirs) {
    EXPECT_FALSE(dir.empty());
    EXPECT_NE(dir, fs::path("."));
  }
}

TEST(PluginSearchPath, CurrentDirectoryIsNeverImplied) {
  TempDir cwd;
  fs::copy_file(fixture("pt_fixture_good"), cwd.path() / "libpt_fixture_good.so");
  std::vector<fs::path> dirs;
  host::PluginRegistry registry;
  {
    ScopedCurrentPath in_cwd(cwd.path());
    ScopedEnv env("PROJTOUR_PLUGIN_PATH", ":");
    dirs = host::PluginRegistry::search_path({});
    registry.load_directories(dirs);
  }
  for (const auto& dir : dirs) EXPECT_TRUE(dir.is_absolute()) << dir;
  EXPECT_EQ(registry.find("fixture_wait"), nullptr);
}

TEST(PluginSearchPath, NamedCurrentDirectoryIsSearched) {
  TempDir cwd;
  fs::copy_file(fixture("pt_fixture_good"), cwd.path() / "libpt_fixture_good.so");
  host::PluginRegistry registry;
  {
    ScopedCurrentPath in_cwd(cwd.path());
    registry.load_directories(host::PluginRegistry::search_path({"."}));
  }
  EXPECT_NE(registry.find("fixture_wait"), nullptr);
}

namespace trust {

// A copy of fixture `name` at dir/file_name with `mode`: a file of its own, never loaded before.
fs::path copy_with_mode(const std::string& name, const fs::path& dir, const std::string& file_name,
                        fs::perms mode) {
  const fs::path file = dir / file_name;
  fs::copy_file(fixture(name), file);
  fs::permissions(file, mode);
  return file;
}

constexpr fs::perms kOwnerOnly = fs::perms::owner_all | fs::perms::group_read |
                                 fs::perms::group_exec | fs::perms::others_read |
                                 fs::perms::others_exec;  // 0755

const std::string kTrustRule =
    "; a plugin path must be writable by its owner and root only "
    "(--allow-writable-plugin-path loads it anyway)";

TEST(PluginTrust, GroupWritableDirectoryIsRefusedNamingItsMode) {
  TempDir dir;
  copy_with_mode("pt_fixture_good", dir.path(), "libpt_fixture_good.so", kOwnerOnly);
  fs::permissions(dir.path(), kOwnerOnly | fs::perms::group_write);
  host::PluginRegistry registry;
  EXPECT_EQ(
      registry.load_directories({dir.path()}),
      (std::vector<std::string>{dir.path().string() +
                                ": plugin directory is group-writable (mode 0775)" + kTrustRule}));
  EXPECT_EQ(registry.find("fixture_wait"), nullptr);
}

TEST(PluginTrust, WorldWritableLibraryIsRefusedNamingItsMode) {
  TempDir dir;
  const fs::path file = copy_with_mode("pt_fixture_good", dir.path(), "libpt_fixture_ww.so",
                                       kOwnerOnly | fs::perms::others_write);
  const std::string refusal =
      file.string() + ": plugin library is world-writable (mode 0757)" + kTrustRule;
  host::PluginRegistry registry;
  EXPECT_EQ(load_error(registry, file), refusal);
  EXPECT_EQ(registry.load_directories({dir.path()}), (std::vector<std::string>{refusal}));
  EXPECT_TRUE(registry.kinds().empty());
  EXPECT_FALSE(projtour::test::mapped_in_this_process(file));
}

// Whoever may write a directory above the plugin directory may swap the whole tree after the
// check; a sticky one (like /tmp, where these tests live) keeps others from renaming ours.
TEST(PluginTrust, WritableDirectoryAboveIsRefusedUnlessSticky) {
  TempDir above;
  const fs::path dir = above / "plugins";
  fs::create_directory(dir);
  fs::permissions(dir, kOwnerOnly);
  copy_with_mode("pt_fixture_good", dir, "libpt_fixture_good.so", kOwnerOnly);
  fs::permissions(above.path(), fs::perms::all);
  host::PluginRegistry registry;
  EXPECT_EQ(registry.load_directories({dir}),
            (std::vector<std::string>{dir.string() + ": plugin directory is under " +
                                      above.path().string() +
                                      ", which is world-writable (mode 0777)" + kTrustRule}));
  EXPECT_EQ(registry.find("fixture_wait"), nullptr);

  fs::permissions(above.path(), fs::perms::all | fs::perms::sticky_bit);
  EXPECT_TRUE(registry.load_directories({dir}).empty());
  EXPECT_NE(registry.find("fixture_wait"), nullptr);
}

// The entry in a trusted directory is only a name: what counts is where the file really is.
TEST(PluginTrust, SymlinkIntoAWritableDirectoryIsRefused) {
  TempDir trusted("trusted");
  TempDir open("open");
  const fs::path real =
      copy_with_mode("pt_fixture_good", open.path(), "libpt_fixture_good.so", kOwnerOnly);
  fs::permissions(open.path(), kOwnerOnly | fs::perms::others_write);
  fs::create_symlink(real, trusted / "libpt_fixture_good.so");
  host::PluginRegistry registry;
  EXPECT_EQ(load_error(registry, trusted / "libpt_fixture_good.so"),
            (trusted / "libpt_fixture_good.so").string() + ": its directory " +
                open.path().string() + " is world-writable (mode 0757)" + kTrustRule);
}

// Tests run as root here, and root may hand a file to anyone; otherwise chown is not ours to do.
TEST(PluginTrust, LibraryOfAnotherUserIsRefused) {
  if (::geteuid() != 0) GTEST_SKIP() << "only root can give a file to another user";
  TempDir dir;
  const fs::path file =
      copy_with_mode("pt_fixture_good", dir.path(), "libpt_fixture_other_user.so", kOwnerOnly);
  ASSERT_EQ(::chown(file.c_str(), 4242, 4242), 0);
  host::PluginRegistry registry;
  EXPECT_EQ(load_error(registry, file),
            file.string() +
                ": plugin library is owned by uid 4242 (mode 0755), neither root nor this user "
                "(uid 0)" +
                kTrustRule);
}

TEST(PluginTrust, AllowOptionAdmitsWritablePaths) {
  TempDir dir;
  const fs::path file =
      copy_with_mode("pt_fixture_good", dir.path(), "libpt_fixture_allowed.so", fs::perms::all);
  fs::permissions(dir.path(), fs::perms::all);
  host::PluginRegistry strict;
  EXPECT_EQ(strict.load_directories({dir.path()}).size(), 1u);
  host::PluginRegistry allowing(host::PluginLoadOptions{true});
  EXPECT_TRUE(allowing.load_directories({dir.path()}).empty());
  EXPECT_EQ(allowing.require("fixture_wait").library, fs::canonical(file));
}

// dlopen runs constructors before any entry point can be asked for: a refused file must never
// reach it. The allowed load at the end shows the mark is really left when the code runs.
TEST(PluginTrust, RefusedLibraryNeverRunsItsConstructor) {
  TempDir marks("marks");
  const fs::path marker = marks / "constructor_ran";
  ScopedEnv env("PROJTOUR_FIXTURE_MARKER", marker.c_str());

  TempDir open_dir("open_dir");
  copy_with_mode("pt_fixture_constructor", open_dir.path(), "libpt_fixture_constructor.so",
                 kOwnerOnly);
  fs::permissions(open_dir.path(), fs::perms::all);
  host::PluginRegistry registry;
  EXPECT_EQ(registry.load_directories({open_dir.path()}).size(), 1u);
  EXPECT_FALSE(fs::exists(marker));

  TempDir dir("file");
  const fs::path open_file =
      copy_with_mode("pt_fixture_constructor", dir.path(), "libpt_fixture_constructor.so",
                     kOwnerOnly | fs::perms::group_write);
  EXPECT_NE(load_error(registry, open_file).find("plugin library is group-writable"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(marker));
  EXPECT_FALSE(projtour::test::mapped_in_this_process(open_file));

  host::PluginRegistry allowing(host::PluginLoadOptions{true});
  EXPECT_EQ(load_error(allowing, open_file),
            open_file.string() + ": not a projtour plugin (no projtour_plugin_descriptor)");
  EXPECT_TRUE(fs::exists(marker));
}

TEST(PluginTrust, BrokenLibraryDoesNotHideAGoodOneFurtherDown) {
  TempDir first("first");
  TempDir second("second");
  TempDir third("third");
  std::ofstream(first / "libpt_fixture_good.so") << std::string(512, 'x');
  fs::create_symlink(second / "libpt_fixture_good.so", second / "libpt_fixture_good.so");
  const fs::path good =
      copy_with_mode("pt_fixture_good", third.path(), "libpt_fixture_good.so", kOwnerOnly);
  host::PluginRegistry registry;
  EXPECT_TRUE(registry.load_directories({first.path(), second.path(), third.path()}).empty());
  EXPECT_EQ(registry.require("fixture_wait").library, fs::canonical(good));
  const std::string instead = " (" + good.string() + " further down the path was loaded instead)";
  EXPECT_EQ(
      registry.warnings(),
      (std::vector<std::string>{(first / "libpt_fixture_good.so").string() +
                                    ": not an ELF shared object (no ELF header)" + instead,
                                (second / "libpt_fixture_good.so").string() +
                                    ": cannot open: Too many levels of symbolic links" + instead}));
}

TEST(PluginTrust, BrokenLibraryWithNoGoodOneIsTheError) {
  TempDir first("first");
  TempDir second("second");
  std::ofstream(first / "libpt_fixture_good.so") << std::string(512, 'x');
  host::PluginRegistry registry;
  EXPECT_EQ(registry.load_directories({first.path(), second.path()}),
            (std::vector<std::string>{(first / "libpt_fixture_good.so").string() +
                                      ": not an ELF shared object (no ELF header)"}));
  EXPECT_TRUE(registry.warnings().empty());
}

}  // namespace trust

}  // namespace
