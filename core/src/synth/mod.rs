//! Analytically rendered light fields with exact disparity ground truth.
