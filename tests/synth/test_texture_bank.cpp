// The texture bank on disk (synth/texture_bank.h) and backgrounds cut from annotated photographs
// (synth/photo_backgrounds.h).
#include "common/test_data.h"
#include "morph/builtin.h"
#include "core/error.h"
#include "core/random.h"
#include "synth/config.h"
#include "synth/photo_backgrounds.h"
#include "synth/scene.h"
#include "synth/texture_bank.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

namespace facesynth::synth {
namespace {

namespace fs = std::filesystem;

TextureBankManifest bank_header_for(const morph::MorphableModel& model, int size) {
    TextureBankManifest h;
    h.model = model.name;
    h.model_checksum = model.checksum();
    h.vertices = model.num_vertices();
    h.size = size;
    return h;
}

cv::Mat solid_texture(int size, uchar r, uchar g, uchar b) { return {size, size, CV_8UC3, cv::Scalar(r, g, b)}; }

class TextureBankTest : public ::testing::Test {
protected:
    static void SetUpTestSuite() { model_ = std::make_unique<morph::MorphableModel>(morph::builtin_model()); }
    static void TearDownTestSuite() { model_.reset(); }
    static std::unique_ptr<morph::MorphableModel> model_;
};
std::unique_ptr<morph::MorphableModel> TextureBankTest::model_;

TEST_F(TextureBankTest, WrittenBankLoadsForItsModelInManifestOrder) {
    const fs::path dir = testkit::fresh_temp_dir("texture_bank_roundtrip");
    const fs::path bank = dir / "bank";
    {
        TextureBankWriter writer(bank, bank_header_for(*model_, 16));
        TextureBankEntry e;
        e.source = "a.jpg";
        e.yaw_deg = 12.5;
        e.skin_srgb = {200, 150, 120};
        writer.add(solid_texture(16, 10, 20, 30), e);
        e.source = "b.jpg";
        writer.add(solid_texture(16, 40, 50, 60), e);
        writer.reject("c.jpg", "pose: yaw 70° beyond ±50°");
        EXPECT_FALSE(fs::exists(bank));  // nothing in place before commit
        writer.commit();
    }
    ASSERT_TRUE(fs::exists(bank / "bank.json"));
    const TextureBankManifest m = read_texture_bank_manifest(bank);
    ASSERT_EQ(m.textures.size(), 2u);
    EXPECT_EQ(m.textures[0].source, "a.jpg");
    EXPECT_DOUBLE_EQ(m.textures[0].yaw_deg, 12.5);
    EXPECT_EQ(m.textures[1].skin_srgb[0], 200);
    ASSERT_EQ(m.rejected.size(), 1u);
    EXPECT_EQ(m.rejected[0].source, "c.jpg");
    const ImageLibrary library = load_texture_bank(bank, *model_);
    ASSERT_EQ(library.size(), 2u);
    EXPECT_EQ(library.image(1).at<cv::Vec3b>(0, 0), cv::Vec3b(40, 50, 60));  // R G B as written
    EXPECT_EQ(library.name(0), m.textures[0].file);
}

TEST_F(TextureBankTest, UncommittedWriterLeavesNothingAndANonBankFolderIsNeverReplaced) {
    const fs::path dir = testkit::fresh_temp_dir("texture_bank_partial");
    {
        TextureBankWriter writer(dir / "bank", bank_header_for(*model_, 16));
        writer.add(solid_texture(16, 1, 2, 3), {});
    }
    EXPECT_FALSE(fs::exists(dir / "bank"));
    for (const auto& entry : fs::directory_iterator(dir)) ADD_FAILURE() << "left behind: " << entry.path();
    fs::create_directories(dir / "photos");
    const std::string message = testkit::error_message_of([&] { TextureBankWriter writer(dir / "photos", bank_header_for(*model_, 16)); });
    EXPECT_NE(message.find("is not a texture bank"), std::string::npos) << message;
    TextureBankWriter writer(dir / "bank", bank_header_for(*model_, 16));
    EXPECT_THROW(writer.add(solid_texture(8, 1, 2, 3), {}), core::Error);  // wrong size
}

TEST_F(TextureBankTest, BadBanksAreRefusedNamingTheFileAndTheProblem) {
    const fs::path dir = testkit::fresh_temp_dir("texture_bank_bad");
    const fs::path bank = dir / "bank";
    {
        TextureBankWriter writer(bank, bank_header_for(*model_, 16));
        writer.add(solid_texture(16, 1, 2, 3), {});
        writer.commit();
    }
    // Made for another model.
    TextureBankManifest other = bank_header_for(*model_, 16);
    other.model = "surrey";
    other.model_checksum = "0123456789abcdef";
    other.vertices = 3448;
    {
        TextureBankWriter writer(dir / "other", other);
        writer.add(solid_texture(16, 1, 2, 3), {});
        writer.commit();
    }
    std::string message = testkit::error_message_of([&] { (void)load_texture_bank(dir / "other", *model_); });
    EXPECT_NE(message.find("bank.json"), std::string::npos) << message;
    EXPECT_NE(message.find("made for model 'surrey'"), std::string::npos) << message;
    // A texture of the wrong size, and one that is not an image.
    cv::imwrite((bank / "textures" / "000000.png").string(), solid_texture(8, 1, 2, 3));
    message = testkit::error_message_of([&] { (void)load_texture_bank(bank, *model_); });
    EXPECT_NE(message.find("000000.png"), std::string::npos) << message;
    std::ofstream(bank / "textures" / "000000.png") << "not a png";
    message = testkit::error_message_of([&] { (void)load_texture_bank(bank, *model_); });
    EXPECT_NE(message.find("cannot read the texture"), std::string::npos) << message;
    // No manifest, not JSON, not a bank.
    fs::create_directories(dir / "empty");
    message = testkit::error_message_of([&] { (void)load_texture_bank(dir / "empty", *model_); });
    EXPECT_NE(message.find("not a texture bank"), std::string::npos) << message;
    std::ofstream(dir / "empty" / "bank.json") << "{";
    message = testkit::error_message_of([&] { (void)load_texture_bank(dir / "empty", *model_); });
    EXPECT_NE(message.find("not valid JSON"), std::string::npos) << message;
    std::ofstream(dir / "empty" / "bank.json") << R"({"format": "something else"})";
    message = testkit::error_message_of([&] { (void)load_texture_bank(dir / "empty", *model_); });
    EXPECT_NE(message.find("not a texture bank manifest"), std::string::npos) << message;
    std::ofstream(dir / "empty" / "bank.json") << R"({"format": "facesynth-texture-bank", "version": 1, "model": "builtin",
        "model_checksum": "x", "vertices": 1, "size": 16, "textures": [{"file": "../../etc/passwd"}]})";
    message = testkit::error_message_of([&] { (void)load_texture_bank(dir / "empty", *model_); });
    EXPECT_NE(message.find("relative path inside the bank"), std::string::npos) << message;
    EXPECT_THROW((void)load_texture_bank(dir / "missing", *model_), core::Error);
}

// A bank of 16² textures, one solid colour per entry, with the entries' fits.
void write_bank_of_fits(const fs::path& bank, const morph::MorphableModel& model, const std::vector<TextureBankEntry>& entries) {
    TextureBankWriter writer(bank, bank_header_for(model, 16));
    for (std::size_t t = 0; t < entries.size(); ++t) writer.add(solid_texture(16, static_cast<uchar>(10 * t), 20, 30), entries[t]);
    writer.commit();
}

// identity.source = "texture": each sample's shape is the one fitted to its texture's photograph,
// stored in the bank; banks made before shapes were stored, and configurations without a bank, are
// refused with the key and the bank named.
TEST_F(TextureBankTest, TextureIdentityIsTheShapeStoredWithTheDrawnTexture) {
    const fs::path dir = testkit::fresh_temp_dir("texture_bank_identity");
    const int components = model_->num_shape_components();
    std::vector<std::vector<float>> shapes(3);
    for (std::size_t t = 0; t < shapes.size(); ++t)
        for (int k = 0; k < components; ++k) shapes[t].push_back(0.1f * static_cast<float>(t + 1) - 0.01f * static_cast<float>(k));
    std::vector<TextureBankEntry> entries(shapes.size());
    for (std::size_t t = 0; t < shapes.size(); ++t) entries[t].shape = shapes[t];
    write_bank_of_fits(dir / "bank", *model_, entries);
    const ImageLibrary library = load_texture_bank(dir / "bank", *model_);
    ASSERT_EQ(library.fits().size(), 3u);
    EXPECT_EQ(library.fits()[2].shape, shapes[2]);  // through bank.json and back

    SynthConfig config;
    config.identity.source = "texture";
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("identity.source"), std::string::npos);
    config.albedo.texture_bank = (dir / "bank").string();
    validate(config);
    std::set<std::size_t> used;
    for (int i = 0; i < 12; ++i) {
        const SampleSpec s = sample_scene(config, *model_, i, nullptr, nullptr, library.fits());
        ASSERT_TRUE(s.texture_choice.has_value());
        const std::size_t t = *s.texture_choice % shapes.size();
        used.insert(t);
        EXPECT_EQ(s.alpha, shapes[t]) << "sample " << i;
        EXPECT_EQ(s.alpha, sample_scene(config, *model_, i, nullptr, nullptr, library.fits()).alpha);  // (seed, i) alone
    }
    EXPECT_GT(used.size(), 1u);
    // Without the shapes (no bank loaded), and from a bank whose entries have none.
    EXPECT_NE(testkit::error_message_of([&] { (void)sample_scene(config, *model_, 0); }).find("identity.source"), std::string::npos);
    const ImageLibrary old_bank({solid_texture(16, 1, 2, 3)}, {"000000.png"}, {TextureFit{}});
    const std::string message = testkit::error_message_of([&] { (void)sample_scene(config, *model_, 0, nullptr, nullptr, old_bank.fits()); });
    EXPECT_NE(message.find("rebuild it"), std::string::npos) << message;
    // A shape of the wrong length, or with a value that is not a number, names the manifest and the key.
    nlohmann::json manifest = nlohmann::json::parse(std::ifstream(dir / "bank" / "bank.json"));
    manifest["textures"][1]["shape"] = std::vector<float>{1.0f, 2.0f};
    std::ofstream(dir / "bank" / "bank.json") << manifest.dump();
    EXPECT_NE(testkit::error_message_of([&] { (void)load_texture_bank(dir / "bank", *model_); }).find("2 shape coefficients"), std::string::npos);
    manifest["textures"][1]["shape"] = {1.0, "x"};
    std::ofstream(dir / "bank" / "bank.json") << manifest.dump();
    EXPECT_NE(testkit::error_message_of([&] { (void)load_texture_bank(dir / "bank", *model_); }).find("shape"), std::string::npos);
}

// identity.texture_jitter: the fitted shape plus N(0, x²) per coefficient, from (seed, i) alone; only
// with identity.source = "texture".
TEST_F(TextureBankTest, TextureIdentityJitterVariesTheFittedShapeBySample) {
    const fs::path dir = testkit::fresh_temp_dir("texture_bank_identity_jitter");
    const int components = model_->num_shape_components();
    std::vector<TextureBankEntry> entries(1);
    entries[0].shape.assign(static_cast<std::size_t>(components), 0.5f);
    write_bank_of_fits(dir / "bank", *model_, entries);
    const ImageLibrary library = load_texture_bank(dir / "bank", *model_);

    SynthConfig config;
    config.albedo.texture_bank = (dir / "bank").string();
    config.identity.texture_jitter = 0.3;
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("identity.texture_jitter"), std::string::npos);  // source random
    config.identity.source = "texture";
    validate(config);
    double sum = 0, sum_sq = 0;
    int n = 0;
    for (int i = 0; i < 40; ++i) {
        const SampleSpec s = sample_scene(config, *model_, i, nullptr, nullptr, library.fits());
        ASSERT_EQ(s.alpha.size(), static_cast<std::size_t>(components));
        EXPECT_EQ(s.alpha, sample_scene(config, *model_, i, nullptr, nullptr, library.fits()).alpha);  // (seed, i) alone
        for (float a : s.alpha) {
            sum += a - 0.5;
            sum_sq += (a - 0.5) * (a - 0.5);
            ++n;
        }
    }
    EXPECT_NEAR(sum / n, 0.0, 0.05);
    EXPECT_NEAR(std::sqrt(sum_sq / n), 0.3, 0.05);
    config.identity.texture_jitter = 0;
    EXPECT_EQ(sample_scene(config, *model_, 3, nullptr, nullptr, library.fits()).alpha, entries[0].shape);
    config.identity.texture_jitter = 4;
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("must be in [0, 3]"), std::string::npos);
}

// expression.source = "texture": each sample's expression is the one fitted to its texture's
// photograph; banks without stored expressions, and configurations without a bank, are refused.
TEST_F(TextureBankTest, TextureExpressionIsTheExpressionStoredWithTheDrawnTexture) {
    const fs::path dir = testkit::fresh_temp_dir("texture_bank_expression");
    const auto components = static_cast<std::size_t>(model_->num_expression_components());
    ASSERT_GT(components, 0u);
    std::vector<std::vector<float>> expressions(3, std::vector<float>(components, 0.0f));
    expressions[1][0] = 0.7f;
    expressions[2].back() = 0.4f;
    std::vector<TextureBankEntry> entries(expressions.size());
    for (std::size_t t = 0; t < expressions.size(); ++t) entries[t].expression = expressions[t];
    write_bank_of_fits(dir / "bank", *model_, entries);
    const ImageLibrary library = load_texture_bank(dir / "bank", *model_);
    ASSERT_EQ(library.fits().size(), 3u);
    EXPECT_EQ(library.fits()[1].expression, expressions[1]);  // through bank.json and back

    SynthConfig config;
    config.expression.source = "texture";
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("expression.source"), std::string::npos);
    config.albedo.texture_bank = (dir / "bank").string();
    validate(config);
    std::set<std::size_t> used;
    for (int i = 0; i < 12; ++i) {
        const SampleSpec s = sample_scene(config, *model_, i, nullptr, nullptr, library.fits());
        const std::size_t t = *s.texture_choice % expressions.size();
        used.insert(t);
        EXPECT_EQ(s.psi, expressions[t]) << "sample " << i;
    }
    EXPECT_GT(used.size(), 1u);
    // A bank made before expressions were stored, and an expression of the wrong length.
    const ImageLibrary old_bank({solid_texture(16, 1, 2, 3)}, {"000000.png"}, {TextureFit{}});
    const std::string message = testkit::error_message_of([&] { (void)sample_scene(config, *model_, 0, nullptr, nullptr, old_bank.fits()); });
    EXPECT_NE(message.find("expression.source"), std::string::npos) << message;
    EXPECT_NE(message.find("rebuild it"), std::string::npos) << message;
    nlohmann::json manifest = nlohmann::json::parse(std::ifstream(dir / "bank" / "bank.json"));
    manifest["textures"][0]["expression"] = std::vector<float>{1.0f};
    std::ofstream(dir / "bank" / "bank.json") << manifest.dump();
    EXPECT_NE(testkit::error_message_of([&] { (void)load_texture_bank(dir / "bank", *model_); }).find("1 expression coefficients"), std::string::npos);
}

// pose.source = "texture": each angle is drawn around the one fitted to the texture's photograph
// (through bank.json), bounded by the configured range; it needs a bank, normal distributions and
// still samples.
TEST_F(TextureBankTest, TexturePoseIsDrawnAroundThePoseFittedToItsPhotograph) {
    const fs::path dir = testkit::fresh_temp_dir("texture_bank_pose");
    std::vector<TextureBankEntry> entries(2);
    entries[0].yaw_deg = 30, entries[0].pitch_deg = 5, entries[0].roll_deg = -4;
    entries[1].yaw_deg = -50, entries[1].pitch_deg = -8, entries[1].roll_deg = 6;
    write_bank_of_fits(dir / "bank", *model_, entries);
    const ImageLibrary library = load_texture_bank(dir / "bank", *model_);
    ASSERT_EQ(library.fits().size(), 2u);
    EXPECT_EQ(library.fits()[1].angles.yaw, -50);  // through bank.json and back

    SynthConfig config;
    config.pose.source = "texture";
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("pose.source"), std::string::npos);  // no bank
    config.albedo.texture_bank = (dir / "bank").string();
    config.pose.yaw = {"normal", -40, 60, 0, 3};
    config.pose.pitch = {"normal", -30, 30, 2, 1};
    config.pose.roll = {"normal", -20, 20, 0, 1};
    validate(config);
    std::array<double, 2> yaw_sum{}, pitch_sum{};
    std::array<int, 2> count{};
    for (int i = 0; i < 200; ++i) {
        const SampleSpec s = sample_scene(config, *model_, i, nullptr, nullptr, library.fits());
        const std::size_t t = *s.texture_choice % entries.size();
        yaw_sum[t] += s.angles.yaw;
        pitch_sum[t] += s.angles.pitch;
        ++count[t];
        EXPECT_GE(s.angles.yaw, -40) << "sample " << i;  // texture 1's -50 is outside the range: its draws stay inside
        EXPECT_NEAR(s.angles.roll, entries[t].roll_deg, 5) << "sample " << i;
        EXPECT_EQ(s.angles.yaw, sample_scene(config, *model_, i, nullptr, nullptr, library.fits()).angles.yaw);  // (seed, i) alone
    }
    ASSERT_GT(count[0], 20);
    ASSERT_GT(count[1], 20);
    EXPECT_NEAR(yaw_sum[0] / count[0], 30, 1);
    EXPECT_NEAR(pitch_sum[0] / count[0], 5 + 2, 0.5);  // the configured mean is an offset
    EXPECT_NEAR(pitch_sum[1] / count[1], -8 + 2, 0.5);
    EXPECT_LT(yaw_sum[1] / count[1], -35);
    // The random source ignores the bank's poses.
    config.pose.source = "random";
    double random_yaw = 0;
    for (int i = 0; i < 200; ++i) random_yaw += sample_scene(config, *model_, i, nullptr, nullptr, library.fits()).angles.yaw;
    EXPECT_NEAR(random_yaw / 200, 0, 1);
    config.pose.source = "texture";
    config.pose.roll.distribution = "uniform";
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("pose.roll.distribution"), std::string::npos);
    config.pose.roll.distribution = "normal";
    config.sequence.frames = 10;
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("still samples"), std::string::npos);
    config.sequence.frames = 0;
    config.pose.source = "photo";
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("pose.source"), std::string::npos);
}

TEST(PhotoBackgrounds, RegionsNeverMeetTheAnnotatedFace) {
    core::Rng rng(5, 0, 0);
    for (int trial = 0; trial < 200; ++trial) {
        const cv::Size image(rng.uniform_int(100, 900), rng.uniform_int(100, 900));
        const double w = rng.uniform(20, 300), h = rng.uniform(20, 300);
        const double x = rng.uniform(-50, image.width), y = rng.uniform(-50, image.height);
        Eigen::Matrix2Xd landmarks(2, 68);
        for (int i = 0; i < 68; ++i) landmarks.col(i) << x + rng.uniform(0, w), y + rng.uniform(0, h);
        const cv::Rect face = face_exclusion_box(image, landmarks);
        const cv::Rect image_rect(cv::Point(0, 0), image);
        const Eigen::Vector2d low = landmarks.rowwise().minCoeff(), high = landmarks.rowwise().maxCoeff();
        for (const cv::Rect& r : background_regions(image, landmarks, 32)) {
            EXPECT_EQ(r & image_rect, r);
            EXPECT_GE(std::min(r.width, r.height), 32);
            EXPECT_EQ((r & face).area(), 0);
            // Not even the landmarks' own box (with the hair above it) reaches into a region.
            EXPECT_TRUE(r.x >= high.x() || r.x + r.width <= low.x() || r.y >= high.y() || r.y + r.height <= low.y() - 0.5 * (high.y() - low.y()))
                << trial;
        }
    }
    EXPECT_THROW((void)background_regions({100, 100}, Eigen::Matrix2Xd(2, 0), 16), core::Error);
    Eigen::Matrix2Xd nan_landmarks = Eigen::Matrix2Xd::Zero(2, 68);
    nan_landmarks(0, 3) = std::nan("");
    EXPECT_THROW((void)background_regions({100, 100}, nan_landmarks, 16), core::Error);
}

}  // namespace
}  // namespace facesynth::synth
