/**
 * @file hetinv.h
 * @brief Umbrella header of libhetinv: include this one.
 *
 * libhetinv recovers per-voxel absorption σa, scattering σs and anisotropy g
 * inside a turbid volume from light injected and measured at its boundary,
 * with a differentiable Monte Carlo renderer and stochastic gradient descent
 * (Gkioulekas, Levin, Zickler, ECCV 2016).
 */
#ifndef HETINV_HETINV_H
#define HETINV_HETINV_H

#include "hetinv/export.h"
#include "hetinv/version.h"
#include "hetinv/result.h"
#include "hetinv/context.h"
#include "hetinv/medium.h"
#include "hetinv/io.h"
#include "hetinv/sampling.h"
#include "hetinv/measurement.h"
#include "hetinv/param.h"
#include "hetinv/estimator.h"
#include "hetinv/bound.h"
#include "hetinv/optimizer.h"
#include "hetinv/acquire.h"

#endif /* HETINV_HETINV_H */
