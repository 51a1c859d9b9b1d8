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

#include <Eigen/LU>
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

// A photograph whose colour tells where each pixel came from: B = x / 2, G = y / 2 (x, y < 510).
cv::Mat position_coded_photo(int width, int height) {
    cv::Mat photo(height, width, CV_8UC3);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) photo.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<uchar>(x / 2), static_cast<uchar>(y / 2), 77);
    return photo;
}

// 68 points spread over a face-sized box at (x, y).
Eigen::Matrix2Xd face_points(double x, double y, double width, double height) {
    core::Rng rng(11, 0, 0);
    Eigen::Matrix2Xd points(2, 68);
    for (int k = 0; k < 68; ++k) points.col(k) << x + rng.uniform(0, width), y + rng.uniform(0, height);
    return points;
}

// background.type = "texture_photo": the square around the face keeps each landmark on the photograph's
// pixel under it and marks what lies beyond the photograph's borders; other faces are masked, the
// labelled one never.
TEST(TextureSurroundings, SquareAroundTheFaceFollowsItsLandmarksAndMasksWhatIsNotThePhotograph) {
    const cv::Mat photo = position_coded_photo(400, 300);
    const Eigen::Matrix2Xd landmarks = face_points(40, 60, 120, 140);  // near the left border: the square leaves the photograph
    PhotoSurroundings around = photo_surroundings(photo, landmarks);
    ASSERT_EQ(around.image.size(), cv::Size(kSurroundingsSide, kSurroundingsSide));
    ASSERT_EQ(around.landmarks.cols(), 68);
    for (int k = 0; k < 68; k += 7) {
        const cv::Vec3b seen = around.image.at<cv::Vec3b>(static_cast<int>(std::lround(around.landmarks(1, k))),
                                                          static_cast<int>(std::lround(around.landmarks(0, k))));
        EXPECT_NEAR(seen[0], landmarks(0, k) / 2, 2.0) << "landmark " << k;
        EXPECT_NEAR(seen[1], landmarks(1, k) / 2, 2.0) << "landmark " << k;
    }
    EXPECT_EQ(around.valid.at<uchar>(kSurroundingsSide / 2, 2), 0);  // left of the photograph
    EXPECT_EQ(around.valid.at<uchar>(kSurroundingsSide / 2, kSurroundingsSide / 2), 255);
    const int valid_before = cv::countNonZero(around.valid);
    // A detection on the labelled face changes nothing; one beside it is masked with its hair and ears.
    const Eigen::Vector2d centre = around.landmarks.rowwise().mean();
    exclude_other_faces(around, {cv::Rect(static_cast<int>(centre.x()) - 30, static_cast<int>(centre.y()) - 30, 60, 60)});
    EXPECT_EQ(cv::countNonZero(around.valid), valid_before);
    const cv::Rect other(300, 250, 50, 50);
    exclude_other_faces(around, {other});
    EXPECT_EQ(around.valid.at<uchar>(275, 325), 0);
    EXPECT_EQ(around.valid.at<uchar>(250 - 30, 325), 0);  // above the box: forehead and hair
    EXPECT_LT(cv::countNonZero(around.valid), valid_before);
    EXPECT_THROW((void)photo_surroundings(photo, Eigen::Matrix2Xd::Constant(2, 68, 5.0)), core::Error);
}

// The photograph is moved by the similarity that takes its landmarks onto the rendered ones; where it
// is not valid the wallpaper under it stays.
TEST(TextureSurroundings, DrawnPhotographFollowsTheRenderedFace) {
    TextureFit fit;
    fit.surroundings = position_coded_photo(kSurroundingsSide, kSurroundingsSide);
    fit.surroundings_valid = cv::Mat(fit.surroundings.size(), CV_8UC1, cv::Scalar(255));
    fit.surroundings_valid(cv::Rect(0, 0, kSurroundingsSide, 40)).setTo(0);  // the top rows: beyond the photograph
    fit.surroundings_landmarks = face_points(120, 120, 150, 160);
    // rendered = 0.6 R(15°) p + (20, 30)
    const double angle = 15 * M_PI / 180, scale = 0.6;
    Eigen::Matrix2d a;
    a << scale * std::cos(angle), -scale * std::sin(angle), scale * std::sin(angle), scale * std::cos(angle);
    const Eigen::Vector2d shift(20, 30);
    const Eigen::Matrix2Xd rendered = (a * fit.surroundings_landmarks).colwise() + shift;
    cv::Mat out(256, 256, CV_8UC3, cv::Scalar(1, 2, 3));
    draw_texture_photo(out, fit, rendered);
    const Eigen::Matrix2d inverse = a.inverse();
    int compared = 0, kept = 0;
    for (int y = 10; y < 256; y += 23)
        for (int x = 10; x < 256; x += 23) {
            const Eigen::Vector2d source = inverse * (Eigen::Vector2d(x, y) - shift);
            if (source.x() < 2 || source.y() < 2 || source.x() > kSurroundingsSide - 3 || source.y() > kSurroundingsSide - 3) continue;
            const cv::Vec3b seen = out.at<cv::Vec3b>(y, x);
            if (source.y() < 38) {
                EXPECT_EQ(seen, cv::Vec3b(1, 2, 3)) << x << "," << y;  // the wallpaper
                ++kept;
            } else if (source.y() > 42) {
                EXPECT_NEAR(seen[0], source.x() / 2, 1.5) << x << "," << y;
                EXPECT_NEAR(seen[1], source.y() / 2, 1.5) << x << "," << y;
                ++compared;
            }
        }
    EXPECT_GT(compared, 20);
    EXPECT_GT(kept, 0);
    EXPECT_THROW(draw_texture_photo(out, TextureFit{}, rendered), core::Error);  // a texture loaded without its photograph
}

// Banks keep the photograph around each face; synth asks for it only with background.type =
// "texture_photo", and a bank made before they were kept, or one missing a file, is refused by name.
TEST_F(TextureBankTest, SurroundingsRoundTripAndBanksWithoutThemAreRefusedByName) {
    const fs::path dir = testkit::fresh_temp_dir("texture_bank_surroundings");
    PhotoSurroundings around = photo_surroundings(position_coded_photo(300, 300), face_points(100, 100, 100, 110));
    exclude_other_faces(around, {cv::Rect(10, 10, 40, 40)});
    {
        TextureBankWriter writer(dir / "bank", bank_header_for(*model_, 16));
        TextureBankEntry e;
        e.source = "a.jpg";
        writer.add(solid_texture(16, 10, 20, 30), e, &around);
        writer.commit();
    }
    const ImageLibrary library = load_texture_bank(dir / "bank", *model_, true);
    ASSERT_EQ(library.fits().size(), 1u);
    const TextureFit& fit = library.fits()[0];
    EXPECT_TRUE(fit.surroundings_landmarks.isApprox(around.landmarks, 1e-9));
    ASSERT_EQ(fit.surroundings.size(), around.image.size());
    EXPECT_EQ(cv::countNonZero(fit.surroundings_valid != around.valid), 0);  // lossless
    cv::Mat difference;
    cv::absdiff(fit.surroundings, around.image, difference);  // JPEG: close, not exact (and RGB now)
    EXPECT_LT(cv::mean(difference)[1], 3.0);
    EXPECT_TRUE(load_texture_bank(dir / "bank", *model_).fits()[0].surroundings.empty());  // not read unless asked

    {
        TextureBankWriter writer(dir / "old", bank_header_for(*model_, 16));
        writer.add(solid_texture(16, 10, 20, 30), TextureBankEntry{});
        writer.commit();
    }
    std::string message = testkit::error_message_of([&] { (void)load_texture_bank(dir / "old", *model_, true); });
    EXPECT_NE(message.find("rebuild"), std::string::npos) << message;
    EXPECT_NE(message.find("bank.json"), std::string::npos) << message;
    fs::remove(dir / "bank" / "surroundings" / "000000_valid.png");
    message = testkit::error_message_of([&] { (void)load_texture_bank(dir / "bank", *model_, true); });
    EXPECT_NE(message.find("000000_valid.png"), std::string::npos) << message;

    SynthConfig config;
    config.background.type = "texture_photo";
    EXPECT_NE(testkit::error_message_of([&] { validate(config); }).find("albedo.texture_bank"), std::string::npos);
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
