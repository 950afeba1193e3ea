#pragma once
// Dark-line (crack) evidence of a pavement image at several scales: the Hessian's largest
// eigenvalue (a dark line is a valley across, flat along), less the gradient (a shadow's or a
// stain's edge has a valley-like lobe beside a strong gradient), each scale in robust σ of its
// own distribution over the searched pixels (aggregate texture sets the noise level).

#include <opencv2/core.hpp>

#include <vector>

namespace rs {

/// RidgeStrength of `grey` (CV_8U) at the Gaussian scales `sigmas_px`: per pixel the largest
/// over the scales of (s − median(s)) / σ(s), σ = 1.4826·MAD over the searched pixels (non-zero
/// in `search`, CV_8U; empty = all), with s = σ²·(λ₁ − max(λ₂, 0)) − σ·|∇I| (λ₁ ≥ λ₂ the
/// Hessian's eigenvalues of the image smoothed at σ). CV_32F. For a dark line narrower than
/// ~2σ, s peaks on its centre; for a step edge of any height the two terms cancel (both
/// ≈ 0.24·step at the lobe), for a dark blob λ₂ removes it.
/// `best_sigma` (optional, CV_32F): per pixel the scale where σ²·λ-less-gradient s itself peaks.
cv::Mat RidgeStrength(const cv::Mat& grey, const cv::Mat& search, const std::vector<double>& sigmas_px,
                      cv::Mat* best_sigma = nullptr);

/// Hysteresis on a strength map: pixels above `low` (and in `search`, CV_8U, empty = all) that
/// are 8-connected to a pixel above `high`. CV_8U 0/255.
cv::Mat Hysteresis(const cv::Mat& strength, const cv::Mat& search, double low, double high);

/// The 8-connected components of `weak` (CV_8U, non-zero = set) that hold a pixel of `seeds`
/// (CV_8U, same size). CV_8U 0/255.
cv::Mat ComponentsWithSeeds(const cv::Mat& weak, const cv::Mat& seeds);

/// Keeps the components of `mask` (8-connected) unlikely to be texture, a contrario: a
/// component whose skeleton is L px long at a median ridge scale σ holds n = L / (2σ) nearly
/// independent samples (the Gaussian-derivative response decorrelates over ~2σ), each above the growth level with the
/// probability p = the share of searched pixels there (`p_low`); texture explains it when N·pⁿ ≥ 1 (N = the searched
/// pixels, the places a path may start). CV_8U 0/255.
cv::Mat MeaningfulComponents(const cv::Mat& mask, const cv::Mat& best_sigma, double p_low, double searched_px);

/// The crack region of a hysteresis mask: pixels within `disc_factor` × σ of their nearest
/// skeleton pixel (σ = its best ridge scale: the scale-normalised valley response of a dark bar
/// w wide peaks at σ = w/2) whose darkness below the background (`darkness`, CV_32F) reaches
/// half the darkness on that skeleton pixel (the full width at half depth of the crack's
/// profile), and the skeleton itself. CV_8U 0/255.
cv::Mat CrackRegion(const cv::Mat& mask, const cv::Mat& best_sigma, const cv::Mat& darkness, double disc_factor);

/// Darkness below the background: median over a square `window_px` wide (odd) − grey. CV_32F.
cv::Mat Darkness(const cv::Mat& grey, int window_px);

}  // namespace rs
