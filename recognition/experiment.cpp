#include "recognition/experiment.h"

#include "frontal/evaluate.h"
#include "frontal/frontalise.h"
#include "core/error.h"
#include "morph/jaw_contour.h"
#include "core/random.h"

#include <opencv2/face.hpp>

#include <cmath>
#include <limits>
#include <numbers>

namespace facesynth::recognition {
namespace {

// A soft sky of random brightness and one directional light from a random direction in front of the
// face: lighting changes from image to image, the face's texture does not.
render::Lighting random_lighting(core::Rng& rng) {
    render::Lighting lighting;
    const auto brightness = static_cast<float>(rng.uniform(0.7, 1.1));
    for (auto& coefficient : lighting.sh)
        for (float& channel : coefficient) channel *= brightness;
    const double azimuth = rng.uniform(-60, 60) * std::numbers::pi / 180, elevation = rng.uniform(-10, 50) * std::numbers::pi / 180;
    const auto intensity = static_cast<float>(rng.uniform(0.1, 0.6));
    render::DirectionalLight light;
    light.direction = {static_cast<float>(std::sin(azimuth) * std::cos(elevation)), static_cast<float>(std::sin(elevation)),
                       static_cast<float>(std::cos(azimuth) * std::cos(elevation))};
    light.colour = {intensity, intensity, intensity};
    lighting.lights.push_back(light);
    return lighting;
}

struct Representations {
    cv::Mat org;
    cv::Mat lm;
    cv::Mat lm_detected;  // probes only, with a LandmarkFinder; empty: not acquired
};

// One identity's images: the gallery views first (in gallery_yaws order), then one probe per bin.
struct IdentityImages {
    std::vector<Representations> gallery;
    std::vector<Representations> probes;
    std::vector<bool> gallery_ok, probes_ok;
};

void check(const ExperimentOptions& o) {
    if (o.identities < 2) throw core::Error("recognition: needs at least 2 identities (impostor pairs), got " + std::to_string(o.identities));
    if (o.gallery_yaws.empty()) throw core::Error("recognition: no gallery yaw");
    if (o.probe_bin_width <= 0 || o.probe_max_yaw < o.probe_bin_width || o.probe_max_yaw > 90)
        throw core::Error("recognition: probe bins need 0 < width <= max yaw <= 90");
    if (o.crop.size < 16 || o.image_size < 64 || o.frontal_size < 32) throw core::Error("recognition: image sizes too small");
    if (!(o.detection_framing >= 1.5 && o.detection_framing <= 4)) throw core::Error("recognition: detection framing must lie in [1.5, 4]");
}

cv::Ptr<cv::face::LBPHFaceRecognizer> lbph(const ExperimentOptions& o) {
    return cv::face::LBPHFaceRecognizer::create(o.lbph.radius, o.lbph.neighbours, o.lbph.grid, o.lbph.grid);
}

// Matches every probe of one bin against the gallery: the distance to its own identity's gallery
// image is genuine, to every other one impostor.
void match(const cv::face::LBPHFaceRecognizer& recogniser, const cv::Mat& probe, int probe_identity, MatchScores& scores) {
    const cv::Ptr<cv::face::StandardCollector> collector = cv::face::StandardCollector::create();
    recogniser.predict(probe, collector);
    for (const auto& [label, distance] : collector->getResults()) (label == probe_identity ? scores.genuine : scores.impostor).push_back(distance);
}

// A probe that could not be acquired: as far from every gallery image as can be.
void match_failure(const std::vector<int>& gallery_labels, int probe_identity, MatchScores& scores) {
    for (int label : gallery_labels)
        (label == probe_identity ? scores.genuine : scores.impostor).push_back(std::numeric_limits<double>::infinity());
}

cv::Mat example_sheet(const std::vector<IdentityImages>& images, const ExperimentOptions& o) {
    const int shown = std::min<int>(o.example_identities, static_cast<int>(images.size()));
    std::vector<cv::Mat> rows;
    for (int i = 0; i < shown; ++i) {
        const IdentityImages& mine = images[static_cast<std::size_t>(i)];
        std::vector<cv::Mat> org, lm;
        for (const auto* views : {&mine.gallery, &mine.probes})
            for (const Representations& r : *views) {
                const cv::Mat blank(o.crop.size, o.crop.size, CV_8UC1, cv::Scalar(0));
                org.push_back(r.org.empty() ? blank : r.org);
                lm.push_back(r.lm.empty() ? blank : r.lm);
            }
        cv::Mat org_row, lm_row;
        cv::hconcat(org, org_row);
        cv::hconcat(lm, lm_row);
        rows.push_back(org_row);
        rows.push_back(lm_row);
    }
    cv::Mat sheet;
    if (!rows.empty()) cv::vconcat(rows, sheet);
    return sheet;
}

}  // namespace

MatchScores match_all_pairs(const std::vector<cv::Mat>& images, const std::vector<int>& identity, const ExperimentOptions& o) {
    if (images.size() != identity.size() || images.size() < 2) throw core::Error("recognition: need at least 2 images, each with an identity");
    // Labels are image positions, so the collector's results name the other image of each pair.
    std::vector<int> positions(images.size());
    for (std::size_t i = 0; i < images.size(); ++i) positions[i] = static_cast<int>(i);
    const auto recogniser = lbph(o);
    recogniser->train(images, positions);
    MatchScores scores;
    for (std::size_t i = 0; i < images.size(); ++i) {
        const cv::Ptr<cv::face::StandardCollector> collector = cv::face::StandardCollector::create();
        recogniser->predict(images[i], collector);
        for (const auto& [other, distance] : collector->getResults())
            if (static_cast<std::size_t>(other) > i)
                (identity[static_cast<std::size_t>(other)] == identity[i] ? scores.genuine : scores.impostor).push_back(distance);
    }
    return scores;
}

ExperimentResult run_experiment(const morph::MorphableModel& model, const ExperimentOptions& o, const std::function<void()>& on_identity,
                                const LandmarkFinder& find_landmarks) {
    check(o);
    const int bins = o.probe_max_yaw / o.probe_bin_width;
    frontal::Frontaliser frontaliser(model);
    const morph::JawContourRegion contour_region = morph::jaw_contour_region(model);  // jaw landmarks on the silhouette, as on photographs
    frontal::FrontaliseOptions frontalise_options;
    frontalise_options.frontal.size = o.frontal_size;
    frontalise_options.mirror_fill = o.mirror_fill;
    ExperimentResult result;
    result.detected = static_cast<bool>(find_landmarks);
    std::vector<int> bin_misses(static_cast<std::size_t>(bins), 0);

    std::vector<IdentityImages> images(static_cast<std::size_t>(o.identities));
    for (int i = 0; i < o.identities; ++i) {
        const auto index = static_cast<std::uint64_t>(i);
        const frontal::TexturedFace face = frontal::make_textured_face(model, frontaliser, o.seed, index, o.isomap_size);
        core::Rng pose_rng = core::make_rng(o.seed, index, core::RandomStream::kPose);
        core::Rng light_rng = core::make_rng(o.seed, index, core::RandomStream::kLighting);
        std::vector<double> yaws(o.gallery_yaws.begin(), o.gallery_yaws.end());
        for (int b = 0; b < bins; ++b) {
            const double magnitude = pose_rng.uniform(b * o.probe_bin_width, (b + 1) * o.probe_bin_width);
            yaws.push_back(pose_rng.uniform() < 0.5 ? -magnitude : magnitude);  // probes turn either way
        }
        IdentityImages& mine = images[static_cast<std::size_t>(i)];
        for (std::size_t v = 0; v < yaws.size(); ++v) {
            frontal::ViewOptions view_options;
            view_options.size = o.image_size;
            view_options.lighting = random_lighting(light_rng);
            const frontal::SyntheticView view = frontal::render_view(frontaliser.renderer(), model, face, yaws[v], view_options, &contour_region);
            Representations r;
            bool ok = true;
            try {
                r.org = eye_aligned_crop(view.image, view.landmarks, o.crop);
                r.lm = frontal_crop(frontaliser.frontalise(view.image, view.landmarks, frontalise_options).frontal.image, o.crop);
            } catch (const core::Error&) {
                ok = false;
                ++result.failed_frontalisations;
            }
            ++result.images;
            const bool gallery = v < o.gallery_yaws.size();
            if (!gallery && find_landmarks) {
                const frontal::ViewOptions wide_options = frontal::with_context(view_options, o.detection_framing);
                const frontal::SyntheticView wide = frontal::render_view(frontaliser.renderer(), model, face, yaws[v], wide_options, &contour_region);
                try {
                    if (const std::optional<Eigen::Matrix2Xd> found = find_landmarks(wide.image, wide.landmarks))
                        r.lm_detected = frontal_crop(frontaliser.frontalise(wide.image, *found, frontalise_options).frontal.image, o.crop);
                } catch (const core::Error&) {
                    r.lm_detected.release();  // a failed fit on found landmarks is a failure to acquire too
                }
                if (r.lm_detected.empty()) {
                    ++result.detector_misses;
                    ++bin_misses[v - o.gallery_yaws.size()];
                }
            }
            (gallery ? mine.gallery : mine.probes).push_back(std::move(r));
            (gallery ? mine.gallery_ok : mine.probes_ok).push_back(ok);
        }
        if (on_identity) on_identity();
    }

    result.examples = example_sheet(images, o);
    for (std::size_t g = 0; g < o.gallery_yaws.size(); ++g) {
        // One recogniser per representation, trained on this gallery pose's images.
        std::vector<cv::Mat> org_gallery, lm_gallery;
        std::vector<int> labels;
        for (int i = 0; i < o.identities; ++i) {
            const IdentityImages& mine = images[static_cast<std::size_t>(i)];
            if (!mine.gallery_ok[g]) continue;
            org_gallery.push_back(mine.gallery[g].org);
            lm_gallery.push_back(mine.gallery[g].lm);
            labels.push_back(i);
        }
        if (labels.size() < 2) throw core::Error("recognition: fewer than 2 gallery images at yaw " + std::to_string(o.gallery_yaws[g]) + " could be made");
        const auto org = lbph(o), lm = lbph(o);
        org->train(org_gallery, labels);
        lm->train(lm_gallery, labels);
        for (int b = 0; b < bins; ++b) {
            BinScores scores;
            scores.gallery_yaw = o.gallery_yaws[g];
            scores.low = b * o.probe_bin_width;
            scores.high = (b + 1) * o.probe_bin_width;
            for (int i = 0; i < o.identities; ++i) {
                const IdentityImages& mine = images[static_cast<std::size_t>(i)];
                if (!mine.probes_ok[static_cast<std::size_t>(b)]) continue;
                match(*org, mine.probes[static_cast<std::size_t>(b)].org, i, scores.org);
                match(*lm, mine.probes[static_cast<std::size_t>(b)].lm, i, scores.lm);
                if (!find_landmarks) continue;
                const cv::Mat& detected = mine.probes[static_cast<std::size_t>(b)].lm_detected;
                if (detected.empty()) match_failure(labels, i, scores.lm_detected);
                else match(*lm, detected, i, scores.lm_detected);
            }
            scores.detector_misses = bin_misses[static_cast<std::size_t>(b)];
            result.bins.push_back(std::move(scores));
        }
    }
    return result;
}

}  // namespace facesynth::recognition
