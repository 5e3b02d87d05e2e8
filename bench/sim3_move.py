#!/usr/bin/env python3
"""bench/sim3_move.py S DIR: the similarity of scale S that bench/registration_sim3.sh and
bench/confirmed_floor.sh move block 0's capture by (a turn of 0.7 rad about a fixed axis and a
shift scaled by S), written as DIR/move_S.json (reg apply's T.json), and DIR/gt_S.json: DIR's
ground_truth.json with block 0's frame moved by it."""
import json, math, sys
s, d = float(sys.argv[1]), sys.argv[2]
a, th = [1 / math.sqrt(5.25), -2 / math.sqrt(5.25), 0.5 / math.sqrt(5.25)], 0.7
c, n = math.cos(th), math.sin(th)
x, y, z = a
R = [[c + x * x * (1 - c), x * y * (1 - c) - z * n, x * z * (1 - c) + y * n],
     [y * x * (1 - c) + z * n, c + y * y * (1 - c), y * z * (1 - c) - x * n],
     [z * x * (1 - c) - y * n, z * y * (1 - c) + x * n, c + z * z * (1 - c)]]
t = [3 * s, -1 * s, 2 * s]
M = [[s * R[i][j] for j in range(3)] + [t[i]] for i in range(3)] + [[0, 0, 0, 1]]
json.dump({"target_from_source": M}, open(d + "/move_%g.json" % s, "w"))
gt = json.load(open(d + "/ground_truth.json"))
B = gt["blocks"][0]["block_from_world"]
gt["blocks"][0]["block_from_world"] = [[sum(M[i][k] * B[k][j] for k in range(4)) for j in range(4)] for i in range(4)]
json.dump(gt, open(d + "/gt_%g.json" % s, "w"))
