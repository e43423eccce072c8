// End-to-end tests of `fleetslam vocab train|info` on the project's scene textures (and the real
// sequences when present).

#include <gtest/gtest.h>

#include "cli_test_util.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

namespace fleetslam {
namespace {

namespace fs = std::filesystem;
using test::read_text;

const fs::path kTextures = fs::path(FLEETSLAM_SOURCE_DIR) / "scenes" / "textures";
const fs::path kTum = fs::path(FLEETSLAM_DATA_DIR) / "tum" / "rgbd_dataset_freiburg1_rpy_200";

class VocabCli : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("fleetslam_vocab_cli_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "images");
    // Six textured images, plus a file that is not an image (ignored).
    for (const char* name : {"books_0.png", "books_1.png", "books_2.png", "carton_0.png", "door.png", "ceiling_tiles.png"}) {
      fs::copy_file(kTextures / name, dir_ / "images" / name);
    }
    std::ofstream(dir_ / "images" / "notes.txt") << "not an image\n";
  }
  void TearDown() override { fs::remove_all(dir_); }

  struct Result {
    int exit_code = -1;
    std::string out;
    std::string err;
  };

  Result run(const std::string& arguments) const {
    const std::string command = "'" FLEETSLAM_CLI "' " + arguments + " >'" + (dir_ / "stdout").string() + "' 2>'" +
                                (dir_ / "stderr").string() + "'";
    const int status = std::system(command.c_str());
    Result result;
    result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    result.out = read_text(dir_ / "stdout");
    result.err = read_text(dir_ / "stderr");
    return result;
  }

  // Trains a small vocabulary from the images folder into `file`.
  Result train(const fs::path& file, const std::string& extra = "") const {
    return run("-q vocab train --images " + quoted(dir_ / "images") + " --out " + quoted(file) +
               " --k 4 --levels 2 --features 300 " + extra);
  }

  nlohmann::json info_json(const fs::path& file) const {
    const Result result = run("vocab info --json " + quoted(file));
    EXPECT_EQ(result.exit_code, 0) << result.err;
    return nlohmann::json::parse(result.out);
  }

  // One error line naming `what`, exit status 2.
  void expect_error(const Result& r, const std::string& what) const {
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err.rfind("fleetslam: error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
  }

  static std::string quoted(const fs::path& path) { return "'" + path.string() + "'"; }

  fs::path dir_;
};

TEST_F(VocabCli, TrainWritesAVocabularyThatInfoDescribes) {
  const fs::path file = dir_ / "out" / "v.fsvoc";  // the folder is created
  const Result trained = train(file);
  ASSERT_EQ(trained.exit_code, 0) << trained.err;
  EXPECT_NE(trained.out.find("wrote " + file.string() + ": k 4, L 2"), std::string::npos) << trained.out;
  ASSERT_TRUE(fs::is_regular_file(file));

  const Result info = run("vocab info " + quoted(file));
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("k:            4\n"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("levels:       2\n"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("images:       6\n"), std::string::npos) << info.out;

  const nlohmann::json j = info_json(file);
  EXPECT_EQ(j["k"], 4);
  EXPECT_EQ(j["levels"], 2);
  EXPECT_EQ(j["training_images"], 6);
  EXPECT_GT(j["words"].get<int>(), 4);
  EXPECT_LE(j["words"].get<int>(), 16);
  EXPECT_GT(j["training_descriptors"].get<int>(), 6 * 50);
  EXPECT_LE(j["training_descriptors"].get<int>(), 6 * 300);
}

TEST_F(VocabCli, TrainingIsDeterministicAndSeeded) {
  ASSERT_EQ(train(dir_ / "a.fsvoc").exit_code, 0);
  ASSERT_EQ(train(dir_ / "b.fsvoc").exit_code, 0);
  ASSERT_EQ(train(dir_ / "c.fsvoc", "--seed 5").exit_code, 0);
  EXPECT_EQ(read_text(dir_ / "a.fsvoc"), read_text(dir_ / "b.fsvoc"));
  EXPECT_NE(read_text(dir_ / "a.fsvoc"), read_text(dir_ / "c.fsvoc"));
}

TEST_F(VocabCli, MaxImagesLimitsTheTrainingSet) {
  ASSERT_EQ(train(dir_ / "v.fsvoc", "--max-images 3").exit_code, 0);
  EXPECT_EQ(info_json(dir_ / "v.fsvoc")["training_images"], 3);
}

TEST_F(VocabCli, InfoReadsDbow2Text) {
  const std::string zeros = " 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0";
  std::ofstream(dir_ / "voc.txt") << "2 1 0 0\n0 1" << zeros << " 0.5\n0 1 1" << zeros.substr(2) << " 0.7\n";
  const Result info = run("vocab info " + quoted(dir_ / "voc.txt"));
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("words:        2"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("images:       unknown (DBoW2 text)"), std::string::npos) << info.out;
}

TEST_F(VocabCli, BadInputEndsWithOneErrorLine) {
  expect_error(run("vocab train --images " + quoted(dir_ / "absent") + " --out " + quoted(dir_ / "v.fsvoc")),
               (dir_ / "absent").string() + ": not a folder");
  fs::create_directories(dir_ / "empty");
  expect_error(run("vocab train --images " + quoted(dir_ / "empty") + " --out " + quoted(dir_ / "v.fsvoc")),
               "no png/jpg images");
  expect_error(run("vocab train --out " + quoted(dir_ / "v.fsvoc")), "no images");
  expect_error(run("vocab train --images " + quoted(dir_ / "images") + " --out " + quoted(dir_ / "v.fsvoc") + " --k 1"),
               "vocabulary.branching: must be in [2, 64], got 1");
  expect_error(run("vocab train --dataset " + quoted(dir_ / "images") + " --out " + quoted(dir_ / "v.fsvoc")),
               (dir_ / "images").string());
  expect_error(train(dir_ / "v.fsvoc", "--max-images 0"), "--max-images: must be -1 (all) or at least 1");
  // Where the vocabulary goes is checked before the images are read, not after the training.
  expect_error(train(dir_ / "images"), "--out is a folder");
  std::ofstream(dir_ / "plain") << "a file, not a folder";
  expect_error(train(dir_ / "plain" / "v.fsvoc"), "cannot create its folder");
  std::ofstream(dir_ / "images" / "broken.png") << "not a png";
  expect_error(train(dir_ / "v.fsvoc"), "broken.png: cannot decode the image");
  EXPECT_FALSE(fs::exists(dir_ / "v.fsvoc"));

  expect_error(run("vocab info " + quoted(dir_ / "absent.fsvoc")), "absent.fsvoc: cannot open");
  expect_error(run("vocab info " + quoted(dir_ / "images" / "books_0.png")), "books_0.png: neither");
  std::ofstream(dir_ / "bad.txt") << "10 6 0 0\n0 0 1 2 3\n";
  expect_error(run("vocab info " + quoted(dir_ / "bad.txt")), "bad.txt:2: expected 'parent is_leaf");
}

TEST_F(VocabCli, TrainsFromARecordedSequence) {
  if (!fs::is_directory(kTum)) GTEST_SKIP() << "real data not found at " << kTum;
  const Result r = run("-q vocab train --dataset " + quoted(kTum) + " --format tum_rgbd --max-images 4 --k 5 --levels 2 --out " +
                       quoted(dir_ / "tum.fsvoc"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = info_json(dir_ / "tum.fsvoc");
  EXPECT_EQ(j["training_images"], 4);
  EXPECT_LE(j["training_descriptors"].get<int>(), 4000);
  EXPECT_GT(j["training_descriptors"].get<int>(), 3000);
}

}  // namespace
}  // namespace fleetslam
