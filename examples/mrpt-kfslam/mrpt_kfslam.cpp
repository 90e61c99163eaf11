// MRPT's range-bearing EKF-SLAM (mrpt::slam::CRangeBearingKFSLAM2D) speaking faultlab's process protocol.
//
// One JSON object per line on stdin/stdout (docs/reference/process-protocol.md); nlohmann::json reads
// and writes them. The filter is MRPT's, untouched; this front end maps faultlab's conventions onto it:
//
//   motion    faultlab's control (v, omega): drive v along the heading, then turn omega. In MRPT an
//             odometry increment is a pose (dx, dy, dphi) in the robot frame composed onto the pose:
//             (v, 0, omega) is exactly faultlab's motion. Its uncertainty is a CPosePDFGaussian on that
//             increment: diag(std_v^2, 0, std_omega^2) (faultlab's noise on v and omega, m and rad).
//   sensor    range (m) and bearing relative to the heading (rad) = MRPT's CObservationBearingRange
//             range and yaw (pitch 0), sensor at the robot's origin; MRPT stores them as float.
//             std_sensor_range / std_sensor_yaw = faultlab's std_range / std_bearing.
//   ids       MRPT's landmark ids are int32; faultlab's are integers below 2^53. Each faultlab id gets
//             an MRPT id in order of first sighting; the estimate maps them back.
//   frame     CRangeBearingKFSLAM2D starts at (0, 0, 0) and skips the prediction while its map is empty
//             (its OnTransitionModel sets out_skipPrediction until the first landmark is in the state), so
//             its map frame is the robot's pose when the first landmark is seen. This front end composes
//             the start pose and the controls up to that step (no observation can correct them) into
//             that frame's origin, and reports MRPT's poses and landmarks composed onto it.
//   steps     before the first observation the pose is that composition (MRPT is not called); from then
//             on one processActionObservation per step (a step without observations passes an empty
//             observation); the estimate's trajectory is the mean pose after each step.
//   seed      the filter draws nothing at random; the seed is accepted and unused.
//
// Noise settings from the environment: MRPT_KFSLAM_STD_V (m), MRPT_KFSLAM_STD_OMEGA_DEG,
// MRPT_KFSLAM_STD_RANGE (m), MRPT_KFSLAM_STD_BEARING_DEG (defaults: the paper's 0.1, 20, 0.3, 10).
// Diagnostics go to stderr only.

#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservationBearingRange.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPosePDFGaussian.h>
#include <mrpt/slam/CRangeBearingKFSLAM2D.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

using nlohmann::json;

namespace
{
double env_or(const char* name, double fallback)
{
	const char* s = std::getenv(name);
	return s ? std::strtod(s, nullptr) : fallback;
}

const double kDeg = M_PI / 180.0;

struct Run
{
	std::unique_ptr<mrpt::slam::CRangeBearingKFSLAM2D> slam;
	std::map<long long, int32_t> to_mrpt;  // faultlab id -> MRPT id
	std::vector<long long> to_faultlab;  // MRPT id -> faultlab id
	std::vector<std::array<double, 3>> trajectory;
	double std_v = 0, std_omega = 0;
	mrpt::poses::CPose2D origin;  // MRPT's map frame in faultlab's frame (see "frame" above)
	bool anchored = false;  // whether MRPT has seen a landmark
};

void send(const json& reply)
{
	std::cout << reply.dump() << '\n' << std::flush;
}

json error(const std::string& message) { return json{{"type", "error"}, {"message", message}}; }

std::array<double, 3> mean_pose(const Run& run)
{
	if (!run.anchored) return {run.origin.x(), run.origin.y(), run.origin.phi()};
	mrpt::poses::CPosePDFGaussian pdf;
	run.slam->getCurrentRobotPose(pdf);
	const mrpt::poses::CPose2D p = run.origin + pdf.mean;
	return {p.x(), p.y(), p.phi()};
}

json reset(Run& run, const json& m)
{
	if (m.at("protocol") != 1) return error("only protocol 1 is spoken here");
	run = Run{};
	run.slam = std::make_unique<mrpt::slam::CRangeBearingKFSLAM2D>();
	run.slam->options.std_sensor_range = static_cast<float>(env_or("MRPT_KFSLAM_STD_RANGE", 0.3));
	run.slam->options.std_sensor_yaw = static_cast<float>(env_or("MRPT_KFSLAM_STD_BEARING_DEG", 10.0) * kDeg);
	run.std_v = env_or("MRPT_KFSLAM_STD_V", 0.1);
	run.std_omega = env_or("MRPT_KFSLAM_STD_OMEGA_DEG", 20.0) * kDeg;
	const auto& p = m.at("pose");
	run.origin = mrpt::poses::CPose2D(p.at(0).get<double>(), p.at(1).get<double>(), p.at(2).get<double>());
	return json{{"type", "ready"}, {"protocol", 1}};
}

json step(Run& run, const json& m)
{
	const double v = m.at("control").at(0).get<double>(), w = m.at("control").at(1).get<double>();
	const auto &r = m.at("ranges"), &b = m.at("bearings"), &ids = m.at("ids");
	if (!run.anchored)
	{
		run.origin = run.origin + mrpt::poses::CPose2D(v, 0.0, w);
		if (r.empty())
		{
			run.trajectory.push_back(mean_pose(run));
			return json{{"type", "ack"}, {"t", m.at("t")}};
		}
	}
	const double v_mrpt = run.anchored ? v : 0.0, w_mrpt = run.anchored ? w : 0.0;
	mrpt::math::CMatrixDouble33 cov;
	cov(0, 0) = run.std_v * run.std_v;
	cov(2, 2) = run.std_omega * run.std_omega;
	mrpt::obs::CActionRobotMovement2D move;
	move.poseChange = mrpt::poses::CPosePDFGaussian::Create(mrpt::poses::CPose2D(v_mrpt, 0.0, w_mrpt), cov);
	auto act = mrpt::obs::CActionCollection::Create();
	act->insert(move);

	auto obs = mrpt::obs::CObservationBearingRange::Create();
	obs->validCovariances = false;
	obs->sensor_std_range = run.slam->options.std_sensor_range;
	obs->sensor_std_yaw = run.slam->options.std_sensor_yaw;
	obs->maxSensorDistance = 1e30f;
	obs->fieldOfView_yaw = static_cast<float>(2 * M_PI);
	for (size_t i = 0; i < r.size(); ++i)
	{
		const long long id = ids.at(i).get<long long>();
		auto it = run.to_mrpt.find(id);
		if (it == run.to_mrpt.end())
		{
			it = run.to_mrpt.emplace(id, static_cast<int32_t>(run.to_faultlab.size())).first;
			run.to_faultlab.push_back(id);
		}
		mrpt::obs::CObservationBearingRange::TMeasurement z;
		z.range = static_cast<float>(r.at(i).get<double>());
		z.yaw = static_cast<float>(b.at(i).get<double>());
		z.pitch = 0;
		z.landmarkID = it->second;
		obs->sensedData.push_back(z);
	}
	auto sf = mrpt::obs::CSensoryFrame::Create();
	sf->insert(obs);
	run.slam->processActionObservation(act, sf);
	run.anchored = true;
	run.trajectory.push_back(mean_pose(run));
	return json{{"type", "ack"}, {"t", m.at("t")}};
}

json estimate(Run& run)
{
	mrpt::poses::CPosePDFGaussian pose;
	std::vector<mrpt::math::TPoint2D> lms;
	std::map<unsigned int, mrpt::maps::CLandmark::TLandmarkID> ids;
	mrpt::math::CVectorDouble state;
	mrpt::math::CMatrixDouble cov;
	if (run.anchored) run.slam->getCurrentState(pose, lms, ids, state, cov);
	json landmarks = json::array();
	for (size_t i = 0; i < lms.size(); ++i)
	{
		double x, y;
		run.origin.composePoint(lms[i].x, lms[i].y, x, y);
		landmarks.push_back({run.to_faultlab.at(ids.at(static_cast<unsigned int>(i))), x, y});
	}
	json trajectory = json::array();
	for (const auto& q : run.trajectory) trajectory.push_back({q[0], q[1], q[2]});
	const auto p = mean_pose(run);
	return json{{"type", "estimate"}, {"pose", {p[0], p[1], p[2]}},
				{"landmarks", landmarks}, {"trajectory", trajectory}};
}
}  // namespace

int main()
{
	Run run;
	std::string line;
	while (std::getline(std::cin, line))
	{
		if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
		try
		{
			const json m = json::parse(line);
			const std::string type = m.at("type");
			if (type == "bye") return 0;
			if (type == "reset") send(reset(run, m));
			else if (!run.slam) send(error(type + " before any reset"));
			else if (type == "step") send(step(run, m));
			else if (type == "estimate") send(estimate(run));
			else send(error("unknown request type " + type));
		}
		catch (const std::exception& e)
		{
			send(error(e.what()));
		}
	}
	return 0;
}
