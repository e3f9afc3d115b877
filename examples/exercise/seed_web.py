"""The seed exercise's web template: sequential code, then a loop at the target frequency.
The same example as the script template (blue_ball onto blue_target), then the loop watches
the ball.

    robocell run examples/exercise/seed_web.py --max-time 1
"""

from GUI import GUI  # noqa: F401  (the template imports it; this exercise shows no images)
from HAL import HAL

# Enter sequential code!
HAL.back_to_home()
pose = HAL.get_object_pose("blue_ball")
WIDTH = 0.3
LENGTH = 0.15
grasp = HAL.generate_grasp("blue_ball", "vertical", pose.position, WIDTH, length=LENGTH)
HAL.pickup("blue_ball", [grasp])
HAL.place("vertical", HAL.get_target_position("blue_target"))
HAL.back_to_home()

while True:
    # Enter iterative code!
    p = HAL.get_object_pose("blue_ball").position
    if p.z < -0.05:  # below the conveyor's top: it is in a tray
        print(f"blue_ball rests at ({p.x:.3f}, {p.y:.3f}, {p.z:.3f})")
        break
